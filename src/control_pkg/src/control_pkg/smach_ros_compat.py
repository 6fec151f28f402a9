"""control_pkg's stand-in for smach_ros on hosts where smach_ros is not installed.

Import it through control_pkg.smach_compat, which picks smach_ros when it exists:

    from control_pkg.smach_compat import smach, SimpleActionState, IntrospectionServer

Like importing smach_ros, importing this module routes SMACH's log output to rospy
(smach.loginfo -> rospy.loginfo, ...) and makes SMACH containers stop on rospy shutdown.
"""
import rospy

from control_pkg.smach_compat import smach
from control_pkg.smach_ros_compat_action import SimpleActionState
from control_pkg.smach_ros_compat_introspection import IntrospectionServer

__all__ = ['SimpleActionState', 'IntrospectionServer']

smach.set_loggers(rospy.loginfo, rospy.logwarn, rospy.logdebug, rospy.logerr)
smach.set_shutdown_check(rospy.is_shutdown)
