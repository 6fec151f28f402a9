#!/usr/bin/env python3
"""Whole simulated missions: the robot stack of harvest_bringup against harvest_sim.

The assertions read the simulator's ground truth (/sim), which only tests and benchmarks may do.
Params:
  ~expect_outcome (str, 'succeeded'): the executive's mission outcome
  ~expect_harvest_all (bool, true): every ripe reachable fruit is collected in the box
  ~estop_during_right_move (bool, false): press the emergency stop while the right arm moves,
      check that every axis halts and the mission pauses, then resume it
  ~expect_error (str, ''): a text the mission's last error must contain (DO_ERROR cases)
  ~timeout (float, ROS-time seconds, 600)
  ~expect_overlaps (bool, false): the task planner ran schedule pipelined and overlapped at
      least one step (its summary's `overlaps`)
"""
import json
import threading
import unittest

import rospy
import rostest
from harvest_sim.msg import SimFruit, SimFruitArray
from harvest_sim.srv import GetSimSummary
from sensor_msgs.msg import JointState
from smach_msgs.msg import SmachContainerStatus
from std_msgs.msg import Bool, String
from std_srvs.srv import Trigger

CUT_STATES = (SimFruit.HARVESTED, SimFruit.COLLECTED, SimFruit.DROPPED, SimFruit.DAMAGED)
RIGHT_ARM = '/SM_ROOT/RUN/MISSION/PICK_TARGET/RIGHT_ARM'


class Watch(object):
    def __init__(self):
        self.cond = threading.Condition()
        self.summary = None
        self.active = {}
        self.velocities = None
        self.fruits = None
        rospy.Subscriber('/sim/fruits', SimFruitArray, self._set('fruits', lambda m: list(m.fruits)))
        rospy.Subscriber('/mission/summary', String, self._set('summary', lambda m: json.loads(m.data)))
        rospy.Subscriber('/harvest_executive/smach/container_status', SmachContainerStatus, self._status)
        rospy.Subscriber('/joint_states', JointState, self._set('velocities', lambda m: list(m.velocity)))

    def _set(self, name, conv):
        def cb(msg):
            with self.cond:
                setattr(self, name, conv(msg))
                self.cond.notify_all()
        return cb

    def _status(self, msg):
        with self.cond:
            self.active[msg.path] = list(msg.active_states)
            self.cond.notify_all()

    def wait(self, predicate, timeout):
        end = rospy.get_time() + timeout   # ROS time: sim.launch sets /use_sim_time
        with self.cond:
            while not predicate():
                left = end - rospy.get_time()
                if left <= 0 or rospy.is_shutdown():
                    return False
                self.cond.wait(min(left, 1.0))
            return True

    def fruits_at_rest(self, timeout=30.0):
        """The simulator's fruit once none is on the suction sleeve any more (or after
        `timeout` ROS seconds, as they are then). The mission's end and the valve's last
        closing reach the world on different topics, so the summary can arrive before the
        world has let the last fruit go into the box."""
        in_hand = (SimFruit.HELD, SimFruit.HARVESTED)
        self.wait(lambda: self.fruits is not None and
                  not any(f.state in in_hand for f in self.fruits), timeout)
        with self.cond:
            return self.fruits


class MissionTest(unittest.TestCase):
    """run_mission becomes test_<test-name> (scenario_case), one name per .test file."""

    def run_mission(self):
        w = WATCH
        timeout = float(rospy.get_param('~timeout', 600.0))
        if rospy.get_param('~estop_during_right_move', False):
            self.estop_and_resume(w)
        self.assertTrue(w.wait(lambda: w.summary is not None, timeout), 'no mission summary')
        s = w.summary
        self.assertEqual(s['outcome'], rospy.get_param('~expect_outcome', 'succeeded'), s)
        if rospy.get_param('~expect_overlaps', False):
            overlapped = [k for k, v in s.get('overlaps', {}).items() if v.get('overlapped')]
            self.assertTrue(overlapped, 'no step overlapped: %s' % s.get('overlaps'))
        expect_error = rospy.get_param('~expect_error', '')
        if expect_error:
            self.assertIn(expect_error, s['last_error'])
        fruits = w.fruits_at_rest()
        self.assertIsNotNone(fruits, 'no /sim/fruits')
        truth = rospy.ServiceProxy('/sim/get_summary', GetSimSummary)()
        rospy.loginfo('mission_test: executive %s; truth: ripe reachable %d, collected %d, dropped %d, damaged %d',
                      s, truth.ripe_reachable, truth.collected, truth.dropped, truth.damaged)
        cut = [f for f in fruits if f.state in CUT_STATES]
        self.assertEqual([f.id for f in cut if not f.ripe], [], 'unripe fruit cut')
        self.assertEqual([f.id for f in cut if not f.reachable], [], 'out-of-reach fruit cut')
        self.assertEqual([(f.id, f.state_name) for f in fruits if f.state in (SimFruit.DROPPED, SimFruit.DAMAGED)],
                         [], 'fruit dropped or damaged')
        if rospy.get_param('~expect_harvest_all', True):
            missed = [f.id for f in fruits if f.ripe and f.reachable and f.state != SimFruit.COLLECTED]
            self.assertEqual(missed, [], 'ripe reachable fruit not harvested: %s' % missed)
            self.assertEqual(s['picked'], truth.collected, 'executive record and ground truth disagree')

    def estop_and_resume(self, w):
        self.assertTrue(w.wait(lambda: w.active.get(RIGHT_ARM) == ['DO_MOVE_ROBOT'], 300.0),
                        'the right arm never moved: %s' % w.active)
        pub = rospy.Publisher('/emergency_stop', Bool, queue_size=1, latch=True)
        pub.publish(Bool(data=True))
        self.assertTrue(w.wait(lambda: w.active.get('/SM_ROOT') == ['DO_STOP'], 60.0), 'no DO_STOP')
        # every axis of the real driver's joint_states comes to rest
        self.assertTrue(w.wait(lambda: bool(w.velocities) and all(abs(v) < 1e-6 for v in w.velocities),
                               30.0), 'axes still moving: %s' % w.velocities)
        self.assertIsNone(w.summary, 'the mission ended instead of pausing')
        rospy.wait_for_service('/task_planner/resume', timeout=30.0)
        resp = rospy.ServiceProxy('/task_planner/resume', Trigger)()
        self.assertTrue(resp.success, resp.message)


def scenario_case(test_name, case=MissionTest):
    """`case` with its run_mission as test_<test_name>: every .test file runs this same node
    under its own test-name (mission_three_targets, mission_estop...), and the JUnit testcase
    (MissionTest.test_mission_estop) then says which scenario passed or failed."""
    name = 'test_' + test_name.rsplit('/', 1)[-1]
    return type(case.__name__, (case,), {name: case.run_mission})


if __name__ == '__main__':
    rospy.init_node('mission_test')     # roslaunch renames the node after the test-name
    WATCH = Watch()
    rostest.rosrun('harvest_bringup', 'mission_test', scenario_case(rospy.get_name()))
