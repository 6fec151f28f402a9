"""vision.launch bag:=FILE (issue 16), parsed with roslaunch's own loader (no master, nothing
started): a recorded mission replaces the cameras, on the bag's clock."""
import os
import shlex

import pytest
import rospkg
from roslaunch.config import ROSLaunchConfig
from roslaunch.xmlloader import XmlLoader

VISION_LAUNCH = os.path.join(rospkg.RosPack().get_path('vision_pkg'), 'launch', 'vision.launch')
CAPTURE_NODES = {'dual_eye_image_capture', 'single_eye_image_capture'}
HARDWARE = ('stereo_source:=bumblebee2', 'hand_source:=v4l2')


def load(*argv):
    config = ROSLaunchConfig()
    XmlLoader().load(VISION_LAUNCH, config, argv=['vision.launch'] + list(argv), verbose=False)
    return config


def players(config):
    return [n for n in config.nodes if (n.package, n.type) == ('rosbag', 'play')]


def names(config):
    return set(n.name for n in config.nodes)


def param(config, name, default=None):
    return config.params[name].value if name in config.params else default


@pytest.mark.parametrize('argv', [(), HARDWARE])
def test_live_cameras_play_no_bag_and_keep_wall_time(argv):
    config = load(*argv)
    assert players(config) == []
    assert param(config, '/use_sim_time') is None
    assert (names(config) & CAPTURE_NODES) == (CAPTURE_NODES if argv else set())


@pytest.mark.parametrize('argv', [(), HARDWARE])
def test_bag_replaces_the_capture_nodes_with_rosbag_play_on_its_clock(argv):
    config = load('bag:=/data/field/row7.bag', *argv)
    [player] = players(config)
    args = shlex.split(player.args)
    assert '--clock' in args
    assert args[:args.index('--topics')].count('/data/field/row7.bag') == 1
    assert param(config, '/use_sim_time') is True
    assert names(config) & CAPTURE_NODES == set()
    # the detection itself still runs, on the replayed images
    assert {'image_processing', 'stereo_image_proc'} <= names(config)


def test_replay_feeds_the_throttled_images_to_the_live_topic_names():
    [player] = players(load('bag:=/tmp/x.bag'))
    remaps = dict(player.remap_args)
    for camera in ('stereo/left', 'stereo/right', 'hand_eye'):
        assert remaps[camera + '/image_raw_throttle'] == camera + '/image_raw'


def test_replay_plays_the_inputs_but_not_the_detections_of_the_recording():
    args = shlex.split(players(load('bag:=/tmp/x.bag', 'bag_rate:=0.5'))[0].args)
    assert args[args.index('-r') + 1] == '0.5'
    played = args[args.index('--topics') + 1:]
    assert {'/tf', '/tf_static', '/stereo/left/camera_info', '/image_processing/goal',
            '/tomato_scan/goal'} <= set(played)
    # what the detection here publishes again must not come from the bag as well
    assert [t for t in played if t.startswith('/detections/') or t.endswith('/result')] == []


def test_replayed_frames_are_not_checked_against_the_live_camera_rates():
    config = load('bag:=/tmp/x.bag')
    assert param(config, '/image_processing/expected_rate') == 0.0
    assert param(config, '/image_processing/hand_expected_rate') == 0.0
