"""sim.launch, parsed with roslaunch's own loader (no master, nothing started): scenario_file
reaches the simulator (it was silently ignored) and every node that reads robot.yaml at start
is required, so a bad robot.yaml (one fatal line, exit 1) stops the whole launch (issue 14)."""
import os

import pytest
import rospkg
from roslaunch.arg_dump import get_args
from roslaunch.config import ROSLaunchConfig
from roslaunch.xmlloader import XmlLoader

SIM_LAUNCH = os.path.join(rospkg.RosPack().get_path('harvest_bringup'), 'launch', 'sim.launch')
SCENARIOS = os.path.join(rospkg.RosPack().get_path('harvest_sim'), 'scenarios')
SCENARIO_READERS = ('/sim/sim_world', '/sim_stereo_camera', '/sim_hand_camera')
ROBOT_YAML_READERS = ('/motion_server', '/kinematics_server', '/sim/sim_world',
                      '/sim/sim_controller', '/sim_stereo_camera', '/sim_hand_camera')


def load(*argv):
    config = ROSLaunchConfig()
    XmlLoader().load(SIM_LAUNCH, config, argv=['sim.launch'] + list(argv), verbose=False)
    return config


def scenario_params(config):
    return dict((node, config.params[node + '/scenario'].value) for node in SCENARIO_READERS)


def test_scenario_file_is_declared_with_a_doc():
    # roslaunch ignores an undeclared name:=value, so the argument must be declared here
    doc, default = get_args([SIM_LAUNCH])['scenario_file']
    assert doc and default == os.path.join(SCENARIOS, 'default.yaml')


def test_scenario_file_reaches_the_world_and_both_cameras(tmp_path):
    path = str(tmp_path / 'my_scenario.yaml')
    assert set(scenario_params(load('scenario_file:=' + path)).values()) == {path}


@pytest.mark.parametrize('argv,name', [((), 'default'), (('scenario:=three_targets',),
                                                           'three_targets')])
def test_scenario_name_still_selects_a_file_of_harvest_sim(argv, name):
    expected = os.path.join(SCENARIOS, name + '.yaml')
    assert set(scenario_params(load(*argv)).values()) == {expected}


def test_every_robot_yaml_reader_is_required():
    nodes = dict(('%s/%s' % (n.namespace.rstrip('/'), n.name), n) for n in load().nodes)
    missing = [name for name in ROBOT_YAML_READERS if name not in nodes]
    assert missing == []
    assert [name for name in ROBOT_YAML_READERS if not nodes[name].required] == []


def test_schedule_reaches_the_task_planner_and_its_default_is_executive_yamls():
    # an empty `schedule` leaves control_pkg's executive.yaml (the only place defaults live)
    assert load().params['/task_planner/schedule'].value == 'paper'
    assert load('schedule:=pipelined').params['/task_planner/schedule'].value == 'pipelined'
    doc, default = get_args([SIM_LAUNCH])['schedule']
    assert doc and default == ''


def test_servo_mode_reaches_the_visual_servo_and_its_default_is_the_papers_step():
    assert load().params['/visual_servo/mode'].value == 'step'
    assert load('servo_mode:=continuous').params['/visual_servo/mode'].value == 'continuous'
