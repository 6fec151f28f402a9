#!/usr/bin/env python3
"""Executive rostests against the mock servers: whole missions, emergency stop/resume, DO_ERROR."""
import json
import threading
import unittest

import rospy
import rostest
from smach_msgs.msg import SmachContainerStatus, SmachContainerStructure
from std_msgs.msg import Bool, Int32, Int32MultiArray, String
from std_srvs.srv import Trigger

from harvest_msgs.msg import EndEffectorGoal, MissionEvent, PickRecord

WAIT = 60.0


class Watcher(object):
    """Collects what the executive publishes; tests wait on its conditions with timeouts."""

    def __init__(self):
        self.cond = threading.Condition()
        self.summary = None
        self.records = []
        self.structures = {}
        self.active = {}
        self.halts = 0
        self.state = ''
        rospy.Subscriber('mission/summary', String, self._summary)
        rospy.Subscriber('mission/pick_records', PickRecord, self._record)
        rospy.Subscriber('/harvest_executive/smach/container_structure', SmachContainerStructure, self._structure)
        rospy.Subscriber('/harvest_executive/smach/container_status', SmachContainerStatus, self._status)
        rospy.Subscriber('mock/halt_count', Int32, self._halt)
        rospy.Subscriber('task_planner/state', String, self._state)
        self.events = []
        rospy.Subscriber('mission/events', MissionEvent,
                         lambda m: self._update(lambda: self.events.append(m)))
        self.goals = []
        self.goals_sub = rospy.Subscriber('mock/goals', String,
                                          lambda m: self._update(lambda: self.goals.append(m.data)))

    def _update(self, fn):
        with self.cond:
            fn()
            self.cond.notify_all()

    def _summary(self, msg):
        self._update(lambda: setattr(self, 'summary', json.loads(msg.data)))

    def _record(self, msg):
        self._update(lambda: self.records.append(msg))

    def _structure(self, msg):
        self._update(lambda: self.structures.__setitem__(msg.path, msg))

    def _status(self, msg):
        self._update(lambda: self.active.__setitem__(msg.path, list(msg.active_states)))

    def _halt(self, msg):
        self._update(lambda: setattr(self, 'halts', msg.data))

    def _state(self, msg):
        self._update(lambda: setattr(self, 'state', msg.data))

    def wait_summary(self):
        """Wait for the mission summary and for the mock's note of it on mock/goals: the summary
        comes on a connection of its own, so only the note tells that every goal the mock saw
        before the mission ended has arrived here."""
        return self.wait(lambda: self.summary is not None
                         and any(g.startswith('summary ') for g in self.goals))

    def wait(self, predicate, timeout=WAIT):
        deadline = rospy.get_time() + timeout
        with self.cond:
            while not predicate():
                left = deadline - rospy.get_time()
                if left <= 0 or rospy.is_shutdown():
                    return False
                self.cond.wait(min(left, 0.5))
            return True


class ExecutiveTest(unittest.TestCase):
    def setUp(self):
        self.w = WATCHER

    def test_mission(self):
        mode = rospy.get_param('~mode')
        getattr(self, 'check_' + mode)()

    def check_mission(self):
        w = self.w
        self.assertTrue(w.wait(lambda: w.summary is not None), 'no mission summary')
        s = w.summary
        self.assertEqual(s['outcome'], 'succeeded', s)
        self.assertEqual(s['points_visited'], 2)
        self.assertEqual((s['picked'], s['unreachable'], s['lost'], s['failed']), (1, 1, 1, 0), s)
        self.assertTrue(w.wait(lambda: len(w.records) == 3), 'expected 3 pick records, got %d' % len(w.records))
        outcomes = sorted(r.outcome for r in w.records)
        self.assertEqual(outcomes, [PickRecord.OUTCOME_PICKED, PickRecord.OUTCOME_UNREACHABLE,
                                    PickRecord.OUTCOME_LOST])
        picked = [r for r in w.records if r.outcome == PickRecord.OUTCOME_PICKED][0]
        for label in ('DO_KINEMATICS', 'DO_MOVE_ROBOT', 'DO_MOVE_ENDEFFECTOR', 'DO_VISUALSERVOING'):
            self.assertIn(label, picked.state_names)
        self.assertEqual(len(picked.state_names), len(picked.state_durations))
        unreachable = [r for r in w.records if r.outcome == PickRecord.OUTCOME_UNREACHABLE][0]
        self.assertIn('beyond reach', unreachable.reason)
        # the introspection graph reads like Figure 14
        paths = ['/SM_ROOT', '/SM_ROOT/RUN/MISSION', '/SM_ROOT/RUN/MISSION/SCAN',
                 '/SM_ROOT/RUN/MISSION/PICK_TARGET/LEFT_ARM']
        self.assertTrue(w.wait(lambda: all(p in w.structures for p in paths)),
                        'structures seen: %s' % sorted(w.structures))
        mission = w.structures['/SM_ROOT/RUN/MISSION']
        for label in ('DO_START', 'PARK_ARMS', 'DO_MOVEBASE', 'SCAN', 'PICK_TARGET', 'DO_ERROR'):
            self.assertIn(label, mission.children)
        self.assertIn('DO_STOP', w.structures['/SM_ROOT'].children)
        scan = w.structures['/SM_ROOT/RUN/MISSION/SCAN']
        self.assertEqual(sorted(scan.children), ['DO_SPATIAL_TEMPORAL', 'DO_TOMATO_SCAN'])
        left = w.structures['/SM_ROOT/RUN/MISSION/PICK_TARGET/LEFT_ARM']
        self.assertIn('DO_VISUALSERVOING', left.children)

    def check_estop(self):
        w = self.w
        # ~stop_in: a container to stop in as soon as any of its states is active (default: the
        # right arm's move)
        path = rospy.get_param('~stop_in', '')
        if path:
            self.assertTrue(w.wait(lambda: bool(w.active.get(path))),
                            '%s never became active: %s' % (path, w.active))
        else:
            path = '/SM_ROOT/RUN/MISSION/PICK_TARGET/RIGHT_ARM'
            self.assertTrue(w.wait(lambda: w.active.get(path) == ['DO_MOVE_ROBOT']),
                            'right-arm move never became active: %s' % w.active)
        pub = rospy.Publisher('emergency_stop', Bool, queue_size=1, latch=True)
        pub.publish(Bool(data=True))
        self.assertTrue(w.wait(lambda: w.halts >= 1), 'axes were not halted')
        self.assertTrue(w.wait(lambda: w.active.get('/SM_ROOT') == ['DO_STOP']), 'not paused in DO_STOP')
        self.assertIsNone(w.summary, 'mission must stay paused, not end')
        rospy.wait_for_service('task_planner/resume', timeout=10.0)
        resp = rospy.ServiceProxy('task_planner/resume', Trigger)()
        self.assertTrue(resp.success, resp.message)
        self.assertTrue(w.wait(lambda: w.summary is not None), 'no mission summary after resume')
        s = w.summary
        self.assertEqual(s['outcome'], 'succeeded', s)
        # ~expect_picked: a fruit stopped while it is placed stays recorded `failed` (DO_STOP)
        self.assertEqual(s['picked'], rospy.get_param('~expect_picked', 2), s)
        # one fruit, one record: the attempt the stop cut short is in the record that ends the
        # fruit (a DO_STOP state there), counted once in `attempted` and once in `interrupted`
        self.assertEqual((s['attempted'], s.get('interrupted')), (2, 1), s)
        self.assertTrue(w.wait(lambda: len(w.records) >= 2), 'expected 2 pick records')
        records = [(r.target_id, r.outcome, r.reason, list(r.state_names)) for r in w.records]
        self.assertEqual(sorted(r[0] for r in records), [1, 2], records)
        stopped = [r for r in records if 'DO_STOP' in r[3]]
        self.assertEqual(len(stopped), 1, records)
        self.assertEqual(stopped[0][3].count('DO_STOP'), 1, records)
        failed = [r for r in records if r[1] == PickRecord.OUTCOME_FAILED]
        self.assertEqual(len(failed), 2 - s['picked'], records)
        self.assertTrue(all(r[2].startswith('interrupted by emergency stop') for r in failed), records)
        estops = [e.detail for e in w.events if e.kind == 'estop']
        self.assertEqual(len(estops), 1, estops)
        self.assertIn('interrupted', estops[0])

    def start_and_finish(self):
        """Start a mission of a task_planner with autostart false; its summary once it succeeded."""
        w = self.w
        # mock/goals is not latched: a goal sent before this subscription is connected is lost
        # (the whole mock mission takes well under a second)
        self.assertTrue(w.wait(lambda: w.goals_sub.get_num_connections() > 0),
                        'mock/goals never connected')
        rospy.wait_for_service('task_planner/start', timeout=WAIT)
        resp = rospy.ServiceProxy('task_planner/start', Trigger)()
        self.assertTrue(resp.success, resp.message)
        self.assertTrue(w.wait_summary(), 'no mission summary (or no note of it on mock/goals)')
        self.assertEqual(w.summary['outcome'], 'succeeded', w.summary)
        return w.summary

    def check_plan(self):
        w = self.w
        # the plan is latched before the mission starts (a farm plan comes from the uploader)
        plan = rospy.wait_for_message('plan/picking_points', Int32MultiArray, timeout=WAIT)
        self.assertEqual(list(plan.data), [2, 0])
        s = self.start_and_finish()
        moves = [g for g in w.goals if g.startswith('move_base')]
        self.assertEqual(moves, ['move_base 2', 'move_base 0'], 'the plan of the day was not followed')
        # the cart never moves with an arm out: the left arm home, the right arm over the box
        # (PARK_ARMS) before it first moves, wherever they stood at start
        before = [g for g in w.goals[:w.goals.index('move_base 2')] if g.startswith('move_robot')]
        self.assertEqual(before, ['move_robot left', 'move_robot right'], w.goals)
        self.assertEqual(s['picked'], 1, s)          # the target at point 1 is not in the plan

    def check_cart_busy(self):
        """A cart move of another client (a manual one, or a restarted task planner's
        predecessor's) is running when the mission starts: WAIT_CART holds the first arm goal
        until it ends (motion_server would refuse the goal: the mock does too)."""
        import actionlib
        from harvest_msgs.msg import MoveBaseAction, MoveBaseGoal
        w = self.w
        self.assertTrue(w.wait(lambda: w.goals_sub.get_num_connections() > 0),
                        'mock/goals never connected')
        other = actionlib.SimpleActionClient('move_base', MoveBaseAction)
        self.assertTrue(other.wait_for_server(rospy.Duration(WAIT)))
        other.send_goal(MoveBaseGoal(picking_point=1))
        self.assertTrue(w.wait(lambda: 'move_base held 1' in w.goals), w.goals)
        stop = rospy.Publisher('mock/cart_stop', Bool, queue_size=1, latch=True)
        rospy.wait_for_service('task_planner/start', timeout=WAIT)
        resp = rospy.ServiceProxy('task_planner/start', Trigger)()
        self.assertTrue(resp.success, resp.message)
        mission = '/SM_ROOT/RUN/MISSION'
        self.assertTrue(w.wait(lambda: 'WAIT_CART' in w.active.get(mission, [])),
                        'WAIT_CART never active: %s' % w.active.get(mission))
        self.assertEqual([g for g in w.goals if g.startswith('move_robot')], [], w.goals)
        stop.publish(Bool(data=True))
        self.assertTrue(w.wait_summary(), 'no mission summary (or no note of it on mock/goals)')
        self.assertEqual(w.summary['outcome'], 'succeeded', w.summary)
        self.assertEqual(w.summary['picked'], 1, w.summary)
        moves = [g for g in w.goals if g.startswith('move_robot') or g.startswith('move_base')]
        self.assertNotIn('move_robot refused', moves)
        first_arm = next(i for i, g in enumerate(moves) if g.startswith('move_robot'))
        self.assertLess(moves.index('move_base stopped'), first_arm, moves)
        self.assertTrue(other.wait_for_result(rospy.Duration(WAIT)))

    def check_cut_check(self):
        w = self.w
        s = self.start_and_finish()
        self.assertEqual((s['picked'], s['unreachable'], s['lost'], s['failed']), (1, 1, 0, 0), s)
        self.assertTrue(w.wait(lambda: len(w.records) == 2), 'expected 2 pick records')
        skipped = [r for r in w.records if r.outcome == PickRecord.OUTCOME_UNREACHABLE][0]
        self.assertEqual(skipped.target_id, 2)
        self.assertIn('cutting hand cannot reach', skipped.reason)
        self.assertNotIn('DO_MOVE_ROBOT', skipped.state_names)
        self.assertNotIn('DO_MOVE_ENDEFFECTOR', skipped.state_names)
        # the only suction of the mission is the picked fruit's
        suction = 'end_effector %d' % EndEffectorGoal.SUCTION_ON
        self.assertEqual(sum(1 for g in w.goals if g == suction), 1, w.goals)

    def check_relocate_depth(self):
        """The look at the held fruit sees it 15 mm nearer along the stereo head's view ray,
        with a smaller circle, 4 mm to the side: the visual servo is sent to the first
        estimate moved along that ray only (relocate_depth_when_smaller), and the fruit is
        picked."""
        import math
        from mock_harvest_servers import view_ray
        w = self.w
        s = self.start_and_finish()
        self.assertEqual((s['picked'], s['lost'], s['failed']), (1, 0, 0), s)
        held = [g for g in w.goals if g.startswith('held_view ')]
        servo = [g for g in w.goals if g.startswith('visual_servo ')]
        self.assertEqual((len(held), len(servo)), (1, 1), w.goals)
        start = [float(v) for v in held[0].split()[1:]]
        target = [float(v) for v in servo[0].split()[1:]]
        ray, _ = view_ray(start)
        shift = float(rospy.get_param('~shift'))
        for got, want in zip(target, [c + shift * r for c, r in zip(start, ray)]):
            self.assertAlmostEqual(got, want, delta=1e-5, msg='servo target %s from %s' % (
                target, start))
        self.assertGreater(math.sqrt(sum((a - b) ** 2 for a, b in zip(target, start))), 0.014)

    def check_pipelined(self):
        """schedule pipelined: the same targets end the same way as in the paper's flow, the
        overlaps ran as Concurrence containers, and the move server never had two goals at once
        (the mock's move_robot would have preempted one: the mission would not succeed)."""
        w = self.w
        s = self.start_and_finish()
        self.assertEqual((s['picked'], s['unreachable'], s['lost'], s['failed']), (2, 1, 1, 0), s)
        self.assertTrue(w.wait(lambda: len(w.records) == 4), 'expected 4 pick records')
        by_id = dict((r.target_id, r.outcome) for r in w.records)
        self.assertEqual(by_id, {1: PickRecord.OUTCOME_PICKED, 2: PickRecord.OUTCOME_UNREACHABLE,
                                 3: PickRecord.OUTCOME_LOST, 4: PickRecord.OUTCOME_PICKED})
        overlaps = s.get('overlaps', {})
        # left_standby: the cutting hand goes to its standby by the first target of the point
        # beside the suction arm (REACH) and waits by the next one after a fruit (STANDBY);
        # without it, the suction arm goes for the next target alone (NEXT_AHEAD)
        standby = rospy.get_param('/task_planner/left_standby')
        steps = ('REACH', 'STANDBY') if standby else ('NEXT_AHEAD', )
        for step in ('APPROACH', 'PLACE') + steps:
            self.assertGreaterEqual(overlaps.get(step, {}).get('overlapped', 0), 1, s)
        if not standby:
            self.assertNotIn('REACH', overlaps, s)
            self.assertNotIn('STANDBY', overlaps, s)
        left = '/SM_ROOT/RUN/MISSION/PICK_TARGET/LEFT_ARM'
        paths = [left + '/APPROACH', '/SM_ROOT/RUN/MISSION/PICK_TARGET/PLACE/PLACE_AND_RETURN']
        self.assertTrue(w.wait(lambda: all(p in w.structures for p in paths)),
                        'structures seen: %s' % sorted(w.structures))
        self.assertEqual(sorted(w.structures[paths[0]].children), ['DO_MOVE_ROBOT', 'DRAW_OUT'])
        self.assertEqual(sorted(w.structures[paths[1]].children), ['DO_MOVE_ROBOT', 'TO_BOX'])
        if rospy.get_param('~expect_overlapping_moves', False):
            # concurrent_arm_moves with a move server that runs a goal per arm: the arms moved
            # at the same time
            self.assertIn('move_robot overlap', w.goals)
        # the first suction of the second picked fruit comes after the first one's suction off
        ee = [g for g in w.goals if g.startswith('end_effector')]
        self.assertEqual(ee[:4], ['end_effector %d' % c for c in (
            EndEffectorGoal.SUCTION_ON, EndEffectorGoal.SHEAR_CUT, EndEffectorGoal.SUCTION_OFF,
            EndEffectorGoal.SUCTION_ON)], w.goals)

    def check_standby(self):
        """left_standby: after fruit 1 the cutting hand waits by target 2 (PLACE_AND_PARK, both
        arms' goals planned); the suction arm's new solution for 2 is refused, so before that
        target is skipped the waiting hand goes home (LEAVE_STANDBY: the skipped target's one
        move), and target 3 is picked after it."""
        w = self.w
        s = self.start_and_finish()
        self.assertEqual((s['picked'], s['unreachable'], s['lost'], s['failed']), (2, 1, 0, 0), s)
        self.assertEqual(s['overlaps'].get('STANDBY', {}).get('overlapped'), 1, s)
        park = '/SM_ROOT/RUN/MISSION/PICK_TARGET/PLACE/PLACE_AND_PARK'
        self.assertTrue(w.wait(lambda: park in w.structures),
                        'structures seen: %s' % sorted(w.structures))
        self.assertEqual(sorted(w.structures[park].children), ['DO_MOVE_ROBOT', 'TO_BOX'])
        self.assertTrue(w.wait(lambda: len(w.records) == 3), 'expected 3 pick records')
        skipped = [r for r in w.records if r.outcome == PickRecord.OUTCOME_UNREACHABLE]
        self.assertEqual([r.target_id for r in skipped], [2])
        # the only move of the skipped target is the waiting hand's way home
        self.assertEqual([n for n in skipped[0].state_names if n == 'DO_MOVE_ROBOT'],
                         ['DO_MOVE_ROBOT'], skipped[0].state_names)

    def check_resume(self):
        """A restarted task planner (~starts 1 given: this is its second start) with the mock's
        unfinished checkpoint: it makes the robot safe as ~expect_first_goals, goes on at the
        checkpoint's picking point with the same mission id, and records ~expect_record_ids
        (each once)."""
        w = self.w
        self.assertTrue(w.wait_summary(), 'no mission summary (or no note of it on mock/goals)')
        s = w.summary
        self.assertEqual((s['mission_id'], s['outcome']), ('m-old', 'succeeded'), s)
        self.assertEqual(s['picked'], rospy.get_param('~expect_picked'), s)
        first = rospy.get_param('~expect_first_goals')
        moves = [g for g in w.goals if not g.startswith('checkpoint') and not g.startswith('summary ')]
        self.assertEqual(moves[:len(first)], first, w.goals)
        self.assertEqual([g for g in moves if g.startswith('move_base')], ['move_base 1'], w.goals)
        checkpoints = lambda: [g for g in w.goals if g.startswith('checkpoint')]  # noqa: E731
        self.assertTrue(w.wait(lambda: checkpoints() and checkpoints()[-1] == 'checkpoint - 0 1'),
                        'the finished checkpoint never came: %s' % w.goals)
        ids = sorted(r.target_id for r in w.records)
        self.assertEqual(ids, sorted(rospy.get_param('~expect_record_ids')), w.records)
        self.assertTrue(all(r.mission_id == 'm-old' for r in w.records))
        restarts = [e for e in w.events if e.kind == 'restart']
        self.assertEqual(len(restarts), 1, w.events)
        self.assertIn('start 2', restarts[0].detail)
        self.assertIn('m-old', restarts[0].detail)
        self.assertEqual(restarts[0].mission_id, 'm-old')

    def check_missing(self):
        w = self.w
        self.assertTrue(w.wait(lambda: w.summary is not None), 'no mission summary')
        s = w.summary
        self.assertEqual(s['outcome'], 'aborted', s)
        self.assertEqual(s['picked'], 0)
        self.assertIn('visual_servo', s['last_error'])
        self.assertTrue(w.wait(lambda: w.halts >= 1), 'DO_ERROR must halt the axes')


if __name__ == '__main__':
    rospy.init_node('executive_test')
    WATCHER = Watcher()
    rostest.rosrun('control_pkg', 'executive_test', ExecutiveTest)
