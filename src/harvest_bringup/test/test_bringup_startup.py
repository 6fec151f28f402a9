"""harvest.launch / sim.launch options of issue 16, parsed with roslaunch's own loader (no master,
nothing started): the operator dashboard (dashboard:=true, the default of harvest.launch only),
mission recording (record:=true, launch/record.launch) and the robot PC's start-up files in
systemd/ (the user unit and the desktop entry name launch files that exist)."""
import configparser
import os
import re
import shlex

import pytest
import rospkg
from roslaunch.config import ROSLaunchConfig
from roslaunch.xmlloader import XmlLoader

PACK = rospkg.RosPack()
BRINGUP = PACK.get_path('harvest_bringup')
LAUNCH = os.path.join(BRINGUP, 'launch')
SYSTEMD = os.path.join(BRINGUP, 'systemd')
VISION_LAUNCH = os.path.join(PACK.get_path('vision_pkg'), 'launch', 'vision.launch')
CAMERAS = ('stereo/left', 'stereo/right', 'hand_eye')


def load(name, *argv):
    config = ROSLaunchConfig()
    XmlLoader().load(os.path.join(LAUNCH, name), config, argv=[name] + list(argv), verbose=False)
    return config


def nodes(config):
    return dict(('%s/%s' % (n.namespace.rstrip('/'), n.name), n) for n in config.nodes)


def dashboard_nodes(config):
    return [n for n in config.nodes
            if (n.package, n.type) == ('visualization_pkg', 'harvest_dashboard')]


def recorders(config):
    return [n for n in config.nodes if (n.package, n.type) == ('rosbag', 'record')]


# --- the operator dashboard ---------------------------------------------------------------

def test_harvest_launch_starts_the_dashboard_by_default():
    assert [n.name for n in dashboard_nodes(load('harvest.launch'))] == ['harvest_dashboard']
    assert len(dashboard_nodes(load('harvest.launch', 'dashboard:=true'))) == 1


def test_harvest_launch_without_the_dashboard_keeps_the_robot_stack():
    with_it, without = load('harvest.launch'), load('harvest.launch', 'dashboard:=false')
    assert dashboard_nodes(without) == []
    assert set(nodes(with_it)) - set(nodes(without)) == {'/harvest_dashboard'}


@pytest.mark.parametrize('argv,count', [((), 0), (('dashboard:=false',), 0),
                                        (('dashboard:=true',), 1)])
def test_sim_launch_starts_the_dashboard_only_when_asked(argv, count):
    assert len(dashboard_nodes(load('sim.launch', *argv))) == count


# --- recording ----------------------------------------------------------------------------

def record_argv(config):
    [recorder] = recorders(config)
    return shlex.split(recorder.args)


def recorded_patterns(config):
    argv = record_argv(config)
    return argv[argv.index('-e') + 1:]


def is_recorded(patterns, topic):
    # rosbag record -e matches each regular expression against the whole topic name
    return any(re.fullmatch(pattern, topic) for pattern in patterns)


@pytest.mark.parametrize('name', ['harvest.launch', 'sim.launch'])
def test_nothing_is_recorded_by_default(name):
    config = load(name)
    assert recorders(config) == []
    assert [n for n in config.nodes if n.package == 'topic_tools'] == []
    assert recorders(load(name, 'record:=false')) == []


@pytest.mark.parametrize('name,default', [('harvest.launch', 'harvest_mission'),
                                          ('sim.launch', 'harvest_sim_mission')])
def test_record_true_records_into_the_bag_prefix(name, default):
    argv = record_argv(load(name, 'record:=true'))
    assert argv[argv.index('-o') + 1] == os.path.join(os.environ['HOME'], '.ros', default)
    argv = record_argv(load(name, 'record:=true', 'bag_prefix:=/data/bags/row7'))
    assert argv[argv.index('-o') + 1] == '/data/bags/row7'


MISSION_TOPICS = ['/tf', '/tf_static', '/joint_states', '/motion_status', '/emergency_stop',
                  '/diagnostics_agg', '/rosout_agg', '/harvest_executive/smach/container_status',
                  '/harvest_executive/smach/container_structure', '/task_planner/state',
                  '/mission/events', '/mission/pick_records', '/mission/summary',
                  '/plan/picking_points', '/image_processing/goal', '/image_processing/result',
                  '/tomato_scan/goal', '/move_robot/goal', '/move_robot/result',
                  '/visual_servo/feedback', '/spatial_temporal/goal', '/self_test/result',
                  '/image_processing/parameter_updates', '/detections/image',
                  '/detections/markers', '/stereo/image_trigger', '/hand_eye/image_trigger',
                  '/stereo/left/camera_info', '/stereo/right/camera_info', '/hand_eye/camera_info']
# full-rate images and what the robot computes again from them
NOT_RECORDED = ['/stereo/left/image_raw', '/stereo/right/image_raw', '/hand_eye/image_raw',
                '/stereo/left/image_rect_color', '/stereo/right/image_color', '/stereo/points2',
                '/stereo/disparity', '/clock', '/rosout', '/diagnostics']


def test_the_mission_topics_are_recorded_and_full_rate_images_are_not():
    patterns = recorded_patterns(load('harvest.launch', 'record:=true'))
    assert [t for t in MISSION_TOPICS if not is_recorded(patterns, t)] == []
    assert [t for t in NOT_RECORDED if is_recorded(patterns, t)] == []
    assert not is_recorded(patterns, '/sim/fruits')


def test_images_are_recorded_through_a_throttle():
    config = load('harvest.launch', 'record:=true')
    patterns = recorded_patterns(config)
    throttles = [shlex.split(n.args) for n in config.nodes
                 if (n.package, n.type) == ('topic_tools', 'throttle')]
    assert sorted(argv[1] for argv in throttles) == sorted(c + '/image_raw' for c in CAMERAS)
    for mode, source, rate, out in throttles:
        assert (mode, out) == ('messages', source + '_throttle')
        assert float(rate) > 0.0
        assert is_recorded(patterns, '/' + out)


def test_sim_launch_records_the_simulator_ground_truth_too():
    patterns = recorded_patterns(load('sim.launch', 'record:=true'))
    for topic in ('/sim/fruits', '/sim/joint_states', '/sim/shear_cut', '/tf',
                  '/mission/summary', '/stereo/left/image_raw_throttle'):
        assert is_recorded(patterns, topic), topic
    assert not is_recorded(patterns, '/stereo/left/image_raw')


def test_vision_replay_plays_every_recorded_camera_topic():
    # what record.launch keeps of the cameras, vision.launch bag:=FILE plays back
    config = ROSLaunchConfig()
    XmlLoader().load(VISION_LAUNCH, config, argv=['vision.launch', 'bag:=/tmp/x.bag'],
                     verbose=False)
    [player] = [n for n in config.nodes if (n.package, n.type) == ('rosbag', 'play')]
    argv = shlex.split(player.args)
    played = argv[argv.index('--topics') + 1:]
    for camera in CAMERAS:
        for topic in ('/%s/image_raw_throttle' % camera, '/%s/camera_info' % camera):
            assert topic in played
    assert '/tf' in played and '/tf_static' in played


# --- start-up files of the robot PC -------------------------------------------------------

def launch_file_of(command):
    """(package, launch file) of a `roslaunch [options] PKG FILE [arg:=value...]` command."""
    argv = shlex.split(command)
    argv = argv[argv.index('roslaunch') + 1:]
    package, name = [a for a in argv if not a.startswith('-')][:2]
    return os.path.join(PACK.get_path(package), 'launch', name)


def read_ini(path):
    parser = configparser.ConfigParser(interpolation=None, strict=True)
    parser.optionxform = str  # keys are case-sensitive in both formats
    with open(path) as stream:
        parser.read_file(stream)
    return parser


def test_the_systemd_unit_starts_harvest_launch_headless_and_restarts():
    unit = read_ini(os.path.join(SYSTEMD, 'harvest-robot.service'))
    assert set(unit.sections()) == {'Unit', 'Service', 'Install'}
    service = unit['Service']
    command = service['ExecStart']
    assert command.split()[0].endswith('/harvest-run')
    assert launch_file_of(command) == os.path.join(LAUNCH, 'harvest.launch')
    assert os.path.isfile(launch_file_of(command))
    # started at boot there is no display: the desktop entry starts the dashboard
    assert 'dashboard:=false' in command.split()
    assert service['Restart'] in ('always', 'on-failure')
    assert service['EnvironmentFile'].lstrip('-').startswith('%h/')
    assert unit['Install']['WantedBy'] == 'default.target'


def test_the_desktop_entry_starts_the_dashboard_without_a_master_of_its_own():
    entry = read_ini(os.path.join(SYSTEMD, 'harvest-dashboard.desktop'))['Desktop Entry']
    assert (entry['Type'], entry['TryExec']) == ('Application', 'harvest-run')
    command = entry['Exec']
    assert command.split()[0] == 'harvest-run'
    path = launch_file_of(command)
    assert path == os.path.join(PACK.get_path('visualization_pkg'), 'launch', 'dashboard.launch')
    assert os.path.isfile(path)
    assert '--wait' in command.split()


def test_the_wrapper_is_executable_and_the_env_example_names_its_variables():
    assert os.access(os.path.join(SYSTEMD, 'harvest-run'), os.X_OK)
    with open(os.path.join(SYSTEMD, 'robot.env.example')) as stream:
        keys = [line.split('=', 1)[0].lstrip('#') for line in stream
                if re.match(r'#?[A-Z_]+=', line)]
    assert 'HARVEST_SETUP' in keys and 'HARVEST_LAUNCH_ARGS' in keys
