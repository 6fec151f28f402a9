"""The mission contract's names agree across the packages that share them.

control_pkg/names.py writes the executive's topics and services. database_pkg, network_pkg and
visualization_pkg do not depend on control_pkg (nor on each other), so each keeps a copy of the
names it uses in its own `names` module; this package depends on all of them and checks every
copy, and the values other packages' configuration and launch files give them, here."""
import os

import rospkg
from roslaunch.config import ROSLaunchConfig
from roslaunch.xmlloader import XmlLoader

from control_pkg import checkpoint, executive_node
from control_pkg import names as control
from control_pkg import smach_ros_compat_introspection as introspection
from database_pkg import names as database
from database_pkg import schema
from network_pkg import names as network
from visualization_pkg import names as visualization


def private(name):
    """'~start' -> 'start': a node's private name, as another node writes it after <node>/."""
    assert name.startswith('~'), name
    return name[1:]


def test_the_store_subscribes_to_the_executives_topics_and_serves_its_calls():
    assert database.PICK_RECORDS == control.PICK_RECORDS
    assert database.EVENTS == control.EVENTS
    assert database.CHECKPOINTS == control.CHECKPOINTS
    assert database.GET_CHECKPOINT == control.GET_CHECKPOINT
    assert database.GET_MISSION_RECORDS == control.GET_MISSION_RECORDS
    assert database.SPATIAL_TEMPORAL == executive_node.load_defaults()['actions']['spatial_temporal']


def test_the_store_keeps_the_executives_checkpoint_phases():
    assert schema.PHASES == checkpoint.PHASES


def test_the_uploader_publishes_the_plan_the_executive_reads():
    assert network.PLAN == control.PLAN


def test_the_dashboard_and_markers_follow_the_executives_names():
    assert visualization.PICK_RECORDS == control.PICK_RECORDS
    assert visualization.EVENTS == control.EVENTS
    assert visualization.SUMMARY == control.SUMMARY
    assert visualization.EXECUTIVE_START == private(control.START)
    assert visualization.EXECUTIVE_RESUME == private(control.RESUME)
    assert visualization.EXECUTIVE_EMERGENCY_STOP == private(control.EMERGENCY_STOP_SERVICE)
    assert visualization.EXECUTIVE_STATE == private(control.STATE)
    assert visualization.EMERGENCY_STOP == control.EMERGENCY_STOP
    assert visualization.HALT_ALL == control.HALT_ALL
    assert visualization.JOINT_STATES == control.JOINT_STATES
    assert visualization.TRACK_PICKING_POINTS == control.TRACK_PICKING_POINTS
    assert visualization.INTROSPECTION_SERVER == control.INTROSPECTION_SERVER
    assert '/' + visualization.SMACH_STRUCTURE == introspection.STRUCTURE_TOPIC
    assert '/' + visualization.SMACH_STATUS == introspection.STATUS_TOPIC
    actions = executive_node.load_defaults()['actions']
    assert (visualization.KINEMATICS, visualization.MOVE_ROBOT) == (actions['kinematics'],
                                                                   actions['move_robot'])


def test_the_dashboards_executive_is_the_launched_task_planner():
    path = os.path.join(rospkg.RosPack().get_path('control_pkg'), 'launch', 'executive.launch')
    config = ROSLaunchConfig()
    XmlLoader().load(path, config, argv=['executive.launch'], verbose=False)
    planners = [n.name for n in config.nodes if (n.package, n.type) == ('control_pkg', 'task_planner')]
    assert planners == [visualization.EXECUTIVE]
