"""The pickable fruit sizes of image_processing.yaml are the suction sleeve's (robot.yaml):
a fruit the sleeve cannot take is never offered for picking, and harvest_sim counts the same
fruit as unreachable."""
import os

import rospkg
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))


def test_image_processing_fruit_radius_range_is_the_suction_sleeves():
    with open(os.path.join(HERE, '..', 'config', 'image_processing.yaml')) as f:
        vision = yaml.safe_load(f)
    robot_yaml = os.path.join(rospkg.RosPack().get_path('harvest_description'), 'config',
                              'robot.yaml')
    with open(robot_yaml) as f:
        sleeve = yaml.safe_load(f)['robot']['arms']['right']['fruit_radius']
    assert (vision['min_fruit_radius'], vision['max_fruit_radius']) == \
        (sleeve['min'], sleeve['max'])
