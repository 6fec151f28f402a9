#!/usr/bin/env python3
"""Whole simulated missions: the robot stack of harvest_bringup against harvest_sim.

The assertions read the simulator's ground truth (/sim), which only tests and benchmarks may do.
Params:
  ~expect_outcome (str, 'succeeded'): the executive's mission outcome
  ~expect_harvest_all (bool, true): every ripe reachable fruit is collected in the box
  ~estop_during_right_move (bool, false): press the emergency stop while the right arm moves,
      check that every axis halts and the mission pauses, then resume it
  ~expect_error (str or list of str, ''): text(s) the mission's last error must contain (DO_ERROR
      cases: each missing component named)
  ~timeout (float, ROS-time seconds, 600)
  ~expect_overlaps (bool, false): the task planner ran schedule pipelined and overlapped at
      least one step (its summary's `overlaps`)
  ~kill_executive_in (str, ''): SIGKILL the task planner as soon as this state of the right arm
      (PICK_TARGET/RIGHT_ARM, e.g. DO_MOVE_ROBOT_PULL: a fruit on the suction cup, still on its
      peduncle) is active; it must respawn and continue the mission (one `restart` event, no
      fruit recorded twice in the database)
  ~axis_fault_in (str, ''), ~axis_fault (str, 'right_boom 3'): as soon as this state of the right
      arm is active, the simulated controller faults that drive (axis, code): the mission must
      end in DO_ERROR naming axis and code, every axis at rest; then the operator's reset
      (motion_pkg's enable_all) and ~resume continue it to the end (one `fault` event, one
      `resume` event of DO_ERROR, no fruit picked twice)
  ~faults (list of str, []): faults the robot must ride through without anyone's help, each
      'PATH/STATE KIND ARGS' (PATH of a container below MISSION: SCAN, PICK_TARGET/RIGHT_ARM,
      PICK_TARGET/LEFT_ARM, PICK_TARGET/PLACE), one after the other, each as soon as its state
      is active (the first time after the previous fault): `link_drop SECONDS` (the simulated
      controller drops every Modbus connection and refuses new ones for that long), `camera
      CAMERA SECONDS` (stereo, hand: publishes nothing for that long), `vacuum_loss` (the held
      fruit drops off the suction cup), `kill NODE` (SIGKILL; the launch respawns it); the
      mission must still end as ~expect_outcome with every check
  ~expect_records (bool, false): the store's records of the mission (get_mission_records)
      agree with the world: as many picked as fruit in the box, no two at one place
  ~expect_dropped (int, 0): fruit that fall to the floor (vacuum_loss while carrying): so many
      are DROPPED in the world, recorded `dropped` and counted in the summary; every other ripe
      reachable fruit is collected
  ~expect_restarts (list of node names, []): each of these nodes (killed by ~faults and respawned)
      has a mission event `restart` naming it, on mission/events and in the store
  ~expect_waist_turn (float, rad, 0: no check): the waist (joint_states' waist_joint) turned at
      least this far during the mission, and is back at 0 at its end (the box is on the cart)
"""
import json
import math
import os
import signal
import threading
import unittest

import rosgraph
import rospy
import rostest
from control_pkg.mission import OUTCOME_NAMES
from harvest_msgs.msg import MissionEvent, PickRecord
from harvest_msgs.srv import GetMissionRecords
from harvest_sim.msg import SimFruit, SimFruitArray
from harvest_sim.srv import FaultWindow, GetSimSummary, SilenceCamera
from sensor_msgs.msg import JointState
from smach_msgs.msg import SmachContainerStatus
from std_msgs.msg import Bool, String
from std_srvs.srv import Trigger, TriggerResponse
try:
    from xmlrpc.client import ServerProxy
except ImportError:  # Python 2
    from xmlrpclib import ServerProxy

CUT_STATES = (SimFruit.HARVESTED, SimFruit.COLLECTED, SimFruit.DROPPED, SimFruit.DAMAGED)
MISSION = '/SM_ROOT/RUN/MISSION'
PICK_TARGET = MISSION + '/PICK_TARGET'
RIGHT_ARM = PICK_TARGET + '/RIGHT_ARM'


class Watch(object):
    def __init__(self):
        self.cond = threading.Condition()
        self.summary = None
        self.active = {}
        self.velocities = None
        self.waist = None             # the waist joint's last position and its largest |turn|
        self.max_waist_turn = 0.0
        self.fruits = None
        self.restarts = []            # node names of the `restart` events on mission/events
        self.records = []             # every PickRecord of mission/pick_records, in order
        rospy.Subscriber('/mission/pick_records', PickRecord, self._record)
        rospy.Subscriber('/mission/events', MissionEvent, self._event)
        rospy.Subscriber('/sim/fruits', SimFruitArray, self._set('fruits', lambda m: list(m.fruits)))
        rospy.Subscriber('/mission/summary', String, self._set('summary', lambda m: json.loads(m.data)))
        rospy.Subscriber('/harvest_executive/smach/container_status', SmachContainerStatus, self._status)
        rospy.Subscriber('/joint_states', JointState, self._joints)

    def _set(self, name, conv):
        def cb(msg):
            with self.cond:
                setattr(self, name, conv(msg))
                self.cond.notify_all()
        return cb

    def _joints(self, msg):
        with self.cond:
            self.velocities = list(msg.velocity)
            if 'waist_joint' in msg.name:
                self.waist = msg.position[msg.name.index('waist_joint')]
                self.max_waist_turn = max(self.max_waist_turn, abs(self.waist))
            self.cond.notify_all()

    def _event(self, msg):
        if msg.kind == 'restart':
            with self.cond:
                self.restarts.append(msg.state)
                self.cond.notify_all()

    def _record(self, msg):
        with self.cond:
            self.records.append(msg)

    def story(self, fruit):
        """What the executive recorded at a missed fruit's picking point (the failure message):
        the fruit's world state and place, then each record of that point with its outcome,
        reason and pick point."""
        p = fruit.position
        lines = ['%s: %s at (%.3f, %.3f, %.3f) map, picking point %d' % (
            fruit.id, fruit.state_name, p.x, p.y, p.z, fruit.picking_point)]
        with self.cond:
            records = [r for r in self.records if r.picking_point == fruit.picking_point]
        for r in records:
            q = r.pick_point.point
            lines.append('  target %d %s%s at (%.3f, %.3f, %.3f) %s' % (
                r.target_id, OUTCOME_NAMES.get(r.outcome, r.outcome),
                ' (%s)' % r.reason if r.reason else '', q.x, q.y, q.z, r.pick_point.header.frame_id))
        return '\n'.join(lines)

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
        kill_in = rospy.get_param('~kill_executive_in', '')
        if kill_in:
            self.kill_executive(w, kill_in)
        fault_in = rospy.get_param('~axis_fault_in', '')
        if fault_in:
            self.drive_fault_and_reset(w, fault_in, rospy.get_param('~axis_fault', 'right_boom 3'))
        for fault in rospy.get_param('~faults', []):
            self.ride_through(w, fault)
        self.assertTrue(w.wait(lambda: w.summary is not None, timeout), 'no mission summary')
        s = w.summary
        self.assertEqual(s['outcome'], rospy.get_param('~expect_outcome', 'succeeded'), s)
        if rospy.get_param('~expect_overlaps', False):
            overlapped = [k for k, v in s.get('overlaps', {}).items() if v.get('overlapped')]
            self.assertTrue(overlapped, 'no step overlapped: %s' % s.get('overlaps'))
        expect_error = rospy.get_param('~expect_error', '')
        for text in ([expect_error] if isinstance(expect_error, str) else expect_error):
            if text:
                self.assertIn(text, s['last_error'])
        fruits = w.fruits_at_rest()
        self.assertIsNotNone(fruits, 'no /sim/fruits')
        truth = rospy.ServiceProxy('/sim/get_summary', GetSimSummary)()
        rospy.loginfo('mission_test: executive %s; truth: ripe reachable %d, collected %d, dropped %d, damaged %d',
                      s, truth.ripe_reachable, truth.collected, truth.dropped, truth.damaged)
        cut = [f for f in fruits if f.state in CUT_STATES]
        self.assertEqual([f.id for f in cut if not f.ripe], [], 'unripe fruit cut')
        self.assertEqual([f.id for f in cut if not f.reachable], [], 'out-of-reach fruit cut')
        self.assertEqual([(f.id, f.state_name) for f in fruits if f.state == SimFruit.DAMAGED],
                         [], 'fruit damaged')
        dropped = [f.id for f in fruits if f.state == SimFruit.DROPPED]
        expect_dropped = int(rospy.get_param('~expect_dropped', 0))
        self.assertEqual(len(dropped), expect_dropped, 'fruit dropped: %s' % dropped)
        self.assertEqual(s.get('dropped', 0), expect_dropped, 'dropped fruit not recorded so: %s' % s)
        if rospy.get_param('~expect_harvest_all', True):
            missed = [f.id for f in fruits if f.ripe and f.reachable and f.state != SimFruit.COLLECTED
                      and f.id not in dropped]
            self.assertEqual(missed, [], 'ripe reachable fruit not harvested: %s\n%s' % (
                missed, '\n'.join(w.story(f) for f in fruits if f.id in missed)))
            self.assertEqual(s['picked'], truth.collected, 'executive record and ground truth disagree')
        if kill_in:
            self.check_records_after_restart(s, truth)
        if fault_in:
            self.check_records_after_fault(s, truth)
        if rospy.get_param('~expect_records', False):
            self.check_records(s, truth)
        expect_restarts = list(rospy.get_param('~expect_restarts', []))
        if expect_restarts:
            self.check_restarts(w, s, expect_restarts)
        expect_waist = float(rospy.get_param('~expect_waist_turn', 0.0))
        if expect_waist > 0.0:
            # joint_states may be a poll behind the summary: wait for the waist's last position
            back = w.wait(lambda: w.waist is not None and abs(w.waist) < 0.01, 10.0)
            with w.cond:
                turn, waist = w.max_waist_turn, w.waist
            self.assertGreaterEqual(turn, expect_waist, 'the waist turned at most %.3f rad' % turn)
            self.assertTrue(back, 'the waist ended at %s rad, not 0' % waist)

    def check_restarts(self, w, s, names):
        """A `restart` event of each node (the task planner sees a respawned node register
        again within its node_watch_period), published and stored."""
        self.assertTrue(w.wait(lambda: all(n in w.restarts for n in names), 60.0),
                        'restart events %s, expected %s' % (w.restarts, names))
        resp = self.stored(s, lambda r: all(n in [e.state for e in r.events if e.kind == 'restart']
                                            for n in names))
        stored = [e.state for e in resp.events if e.kind == 'restart']
        self.assertTrue(all(n in stored for n in names), 'stored restart events %s' % stored)

    def stored(self, s, ready, timeout=30.0):
        """get_mission_records of the mission once `ready(response)` holds, or its last answer
        after `timeout` s (ROS time). The database stores the records and events as it hears
        them, each topic on a connection of its own, so the last ones may be stored a step
        after the summary came here."""
        rospy.wait_for_service('/get_mission_records', timeout=30.0)
        get = rospy.ServiceProxy('/get_mission_records', GetMissionRecords)
        deadline = rospy.get_time() + timeout
        while True:
            resp = get(mission_id=s['mission_id'])
            self.assertTrue(resp.success, resp.message)
            if ready(resp) or rospy.get_time() >= deadline or rospy.is_shutdown():
                return resp
            rospy.sleep(0.2)

    @staticmethod
    def picked_count(resp):
        return sum(1 for r in resp.records if r.outcome == PickRecord.OUTCOME_PICKED)

    def kill_executive(self, w, label):
        self.assertTrue(w.wait(lambda: w.active.get(RIGHT_ARM) == [label], 300.0),
                        '%s never became active: %s' % (label, w.active))
        pid = self.sigkill('/task_planner')
        rospy.logwarn('mission_test: SIGKILL of task_planner (pid %d) in %s', pid, label)

    def sigkill(self, node):
        """SIGKILL a node of the launch (pid from its XML-RPC getPid); returns the pid."""
        uri = rosgraph.Master('/mission_test').lookupNode(node)
        self.assertTrue(uri, '%s not registered' % node)
        code, _msg, pid = ServerProxy(uri).getPid('/mission_test')
        self.assertEqual(code, 1)
        os.kill(pid, signal.SIGKILL)
        return pid

    def check_records(self, s, truth):
        """The store holds every record of the mission once: as many picked as fruit in the
        box, no two at one place."""
        resp = self.stored(s, lambda r: len(r.records) >= s['attempted'] and
                           any(e.kind == 'summary' for e in r.events))
        picked = [r for r in resp.records if r.outcome == PickRecord.OUTCOME_PICKED]
        self.assertEqual(len(picked), truth.collected, [(r.target_id, r.outcome, r.reason) for r in resp.records])
        self.assertEqual(len(resp.records), s['attempted'], 'records of the summary not all stored')
        self.assert_no_two_at_one_place(resp.records)
        kinds = [e.kind for e in resp.events]
        self.assertEqual(kinds.count('summary'), 1, kinds)

    def ride_through(self, w, spec):
        """One fault of ~faults, injected once its state is active."""
        where, kind = spec.split()[:2]
        args = spec.split()[2:]
        container, label = where.rsplit('/', 1)
        path = MISSION + '/' + container
        with w.cond:
            w.active.pop(path, None)              # the first time after the previous fault
        # `in`: a Concurrence (SCAN) has several active children
        self.assertTrue(w.wait(lambda: label in (w.active.get(path) or []), 300.0),
                        '%s never became active: %s' % (where, w.active))
        if kind == 'link_drop':
            resp = rospy.ServiceProxy('/sim/sim_controller/drop_connections', FaultWindow)(
                duration=float(args[0]))
        elif kind == 'camera':
            resp = rospy.ServiceProxy('/sim/sim_world/camera_silence', SilenceCamera)(
                camera=args[0], duration=float(args[1]))
        elif kind == 'vacuum_loss':
            resp = rospy.ServiceProxy('/sim/sim_world/vacuum_loss', Trigger)()
        elif kind == 'kill':
            resp = TriggerResponse(success=True, message='pid %d killed' % self.sigkill(args[0]))
        else:
            self.fail('unknown fault kind %r in %r' % (kind, spec))
        self.assertTrue(resp.success, resp.message)
        rospy.logwarn('mission_test: fault %r: %s', spec, resp.message)

    def drive_fault_and_reset(self, w, label, fault):
        """A drive fault mid-move: DO_ERROR names the axis and its code, every axis comes to
        rest; the operator clears the fault (enable_all) and resumes (task_planner/resume)."""
        axis, code = fault.split()
        with w.cond:
            w.active.pop(RIGHT_ARM, None)         # a move after an emergency stop's resume
        self.assertTrue(w.wait(lambda: w.active.get(RIGHT_ARM) == [label], 300.0),
                        '%s never became active: %s' % (label, w.active))
        rospy.set_param('/sim/sim_controller/fault', 'axis_fault %s' % fault)
        resp = rospy.ServiceProxy('/sim/sim_controller/inject_fault', Trigger)()
        self.assertTrue(resp.success, resp.message)
        rospy.logwarn('mission_test: drive fault %s in %s: %s', fault, label, resp.message)
        self.assertTrue(w.wait(lambda: w.summary is not None, 120.0), 'no DO_ERROR: %s' % w.active)
        with w.cond:
            s, w.summary = w.summary, None          # the next summary is the continued mission's
        self.assertEqual(s['outcome'], 'aborted', s)
        self.assertIn(axis, s['last_error'])
        self.assertIn(code, s['last_error'])
        self.assertTrue(w.wait(lambda: bool(w.velocities) and all(abs(v) < 1e-6 for v in w.velocities),
                               30.0), 'axes still moving after DO_ERROR: %s' % w.velocities)
        rospy.wait_for_service('/enable_all', timeout=30.0)
        resp = rospy.ServiceProxy('/enable_all', Trigger)()
        self.assertTrue(resp.success, resp.message)
        resp = rospy.ServiceProxy('/task_planner/resume', Trigger)()
        self.assertTrue(resp.success, resp.message)
        rospy.loginfo('mission_test: after the reset: %s', resp.message)

    def check_records_after_fault(self, s, truth):
        """One `fault` event and one `resume` of DO_ERROR; the picked records agree with the
        world, and no fruit is picked twice (the fruit DO_ERROR interrupted has a failed record
        and, tried again, a picked one)."""
        resp = self.stored(s, lambda r: self.picked_count(r) >= truth.collected)
        kinds = [(e.kind, e.state) for e in resp.events]
        self.assertEqual(kinds.count(('fault', 'DO_ERROR')), 1, kinds)
        self.assertEqual(kinds.count(('resume', 'DO_ERROR')), 1, kinds)
        picked = [r for r in resp.records if r.outcome == PickRecord.OUTCOME_PICKED]
        self.assertEqual(len(picked), truth.collected, [(r.target_id, r.outcome, r.reason) for r in resp.records])
        self.assert_no_two_at_one_place(picked)
        if rospy.get_param('~estop_during_right_move', False):
            # one fruit, one record across the emergency stop: the attempt it cut short is a
            # DO_STOP state of the record that ends that fruit, never a record of its own; only
            # DO_ERROR's failed record shares a place with a later one
            stopped = [(r.target_id, r.outcome) for r in resp.records if 'DO_STOP' in r.state_names]
            self.assertEqual(len(stopped), 1, stopped)
            self.assertEqual(s.get('interrupted'), 1, s)
            axis = rospy.get_param('~axis_fault', 'right_boom 3').split()[0]
            self.assert_no_two_at_one_place([r for r in resp.records if not (
                r.outcome == PickRecord.OUTCOME_FAILED and axis in r.reason)])

    def assert_no_two_at_one_place(self, records):
        where = [(r.picking_point, r.pick_point.point) for r in records]
        for i, (pa, a) in enumerate(where):
            for pb, b in where[i + 1:]:
                gap = math.sqrt((a.x - b.x) ** 2 + (a.y - b.y) ** 2 + (a.z - b.z) ** 2)
                self.assertFalse(pa == pb and gap < 0.03, 'a fruit recorded twice: %s' %
                                 [(r.picking_point, r.target_id, r.outcome) for r in records])

    def check_records_after_restart(self, s, truth):
        """The store has one `restart` event of the mission, its pick records agree with the
        world, and no fruit has two records (the same place, ids of two scans may repeat)."""
        resp = self.stored(s, lambda r: self.picked_count(r) >= truth.collected and
                           any(e.kind == 'restart' for e in r.events))
        restarts = [e for e in resp.events if e.kind == 'restart']
        self.assertEqual(len(restarts), 1, [(e.kind, e.detail) for e in resp.events])
        self.assertIn(s['mission_id'], restarts[0].detail)
        picked = [r for r in resp.records if r.outcome == PickRecord.OUTCOME_PICKED]
        self.assertEqual(len(picked), truth.collected, [(r.target_id, r.reason) for r in resp.records])
        self.assert_no_two_at_one_place(resp.records)

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
