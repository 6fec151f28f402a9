"""The glue of the executive's graph (executive.py): `_Callbacks`, the goal_cb / result_cb of its
action states.

Userdata in, the pure builders and readers of executive_goals.py, the mission's shared object
(executive_states.MissionContext), its checkpoint and its log out; grouped as the graph runs:
RESUME, DO_START, DO_MOVEBASE and SCAN, the arms, the pull and the look at the held fruit.
"""
import rospy

from harvest_msgs.msg import StartGoal, MoveBaseGoal, SpatialTemporalGoal, EndEffectorGoal
from control_pkg import checkpoint as checkpoint_lib
from control_pkg import executive_goals as goals


class _Callbacks(object):
    """goal_cb / result_cb of the action states: userdata in, pure builders and readers of
    executive_goals, the mission's shared object and its log out. A result_cb returns None
    (the server's outcome stands) or an outcome of its state."""

    def __init__(self, context):
        self.context = context
        cfg = context.config
        self.frame = cfg['base_frame']
        self.peduncle_gap = float(cfg['peduncle_gap'])
        self.approach = float(cfg['left_approach_standoff'])
        self.relocate_tolerance = float(cfg['relocate_tolerance'])
        self.relocate_radius_tolerance = float(cfg['relocate_radius_tolerance'])
        self.relocate_depth = bool(cfg['relocate_depth_when_smaller'])
        self.components = list(cfg['self_test_components'])
        self.skip_tolerance = float(cfg['resume_skip_tolerance'])

    # --- after a restart (RESUME) ----------------------------------------------------------------
    def resume_check(self, ud):
        return 'resume' if self.context.resume is not None else 'start'

    def resume_first(self, ud):
        return self.context.resume.steps[0]

    def resume_done(self, ud):
        plan = self.context.resume
        self.context.resume = None
        self.context.publish_event('state', 'RESUME', 'robot safe after the restart: %s'
                                   % (plan.why if plan is not None else ''))
        return 'done'

    # --- DO_START, DO_MOVEBASE, SCAN -------------------------------------------------------------
    def start_goal(self, ud, goal):
        return StartGoal(components=self.components)

    def start_result(self, ud, status, result):
        failure = goals.self_test_failure(result)
        if failure is not None:
            self.context.fail('DO_START: self-test failed: %s' % failure)
            return 'aborted'
        self.context.recorder.start(self.context.now())
        self.context.publish_event('state', 'DO_START', 'self-test passed')
        return None

    def movebase_goal(self, ud, goal):
        return MoveBaseGoal(picking_point=int(ud.picking_point))

    def movebase_result(self, ud, status, result):
        if result is not None:
            ud.track_position = result.track_position
        return None

    def scan_goal(self, ud, goal):
        return goals.scan_goal(ud.picking_point, self.frame)

    def scan_result(self, ud, status, result):
        if result is None or not result.success:
            return None
        tomatoes = result.tomatoes.tomatoes
        pickable = goals.pickable_in_order(tomatoes)
        skip = self.context.skip.get(ud.picking_point)
        if skip:
            kept = checkpoint_lib.not_done(pickable, skip, self.skip_tolerance)
            if len(kept) != len(pickable):
                rospy.loginfo('executive: %d target(s) at picking point %d recorded before the '
                              'restart: not tried again', len(pickable) - len(kept),
                              ud.picking_point)
            pickable = kept
        self.context.scene = goals.scene_of(tomatoes, self.frame)
        self.context.gone = set()
        ud.targets = pickable
        rospy.loginfo('executive: %d pickable of %d tomatoes at picking point %d', len(pickable),
                      len(tomatoes), ud.picking_point)
        return 'none' if not pickable else None

    def st_goal(self, ud, goal):
        return SpatialTemporalGoal(mission_id=self.context.recorder.mission_id,
                                   picking_point=int(ud.picking_point),
                                   track_position=float(ud.track_position))

    # --- arms ----------------------------------------------------------------------------------
    def suction_goal(self, ud, goal):
        return goals.suction_kinematics_goal(ud.target, self.peduncle_gap)

    def cut_check_goal(self, ud, goal):
        return goals.cut_check_kinematics_goal(ud.target, self.peduncle_gap, self.approach)

    def cutting_goal(self, ud, goal):
        return goals.cutting_kinematics_goal(ud.target, self.peduncle_gap, self.approach)

    def kinematics_result(self, ud, status, result):
        joints, reason = goals.kinematics_solution(result)
        if reason is not None:
            self.context.fail('DO_KINEMATICS: unreachable: %s' % reason)
            return 'unreachable'
        if joints is not None:
            ud.joint_goal = joints
        return None

    def cut_check_result(self, ud, status, result):
        """The cutting hand's solution before suction: only whether it exists counts."""
        _, reason = goals.kinematics_solution(result)
        if reason is not None:
            self.context.fail('DO_KINEMATICS: the cutting hand cannot reach the peduncle: %s'
                              % reason)
            return 'unreachable'
        return None

    def move_goal(self, arm, key='joint_goal', phase=None):
        """phase: the checkpoint phase this move starts (the pull)."""
        def cb(ud, goal):
            if phase is not None:
                self.context.checkpoint.phase(phase)
            return goals.move_goal(arm, ud[key])
        return cb

    def move_result(self, ud, status, result):
        failure = goals.move_failure(status, result)
        if failure is not None:
            self.context.fail('DO_MOVE_ROBOT: %s' % failure)
            return 'aborted'
        return None

    def ee_result(self, ud, status, result):
        return self._reported('DO_MOVE_ENDEFFECTOR', status, result)

    #: checkpoint phase a command starts (the valve may be open from the moment it is sent)
    _EE_PHASE = {EndEffectorGoal.SUCTION_ON: checkpoint_lib.PHASE_SUCTION,
                 EndEffectorGoal.SHEAR_CUT: checkpoint_lib.PHASE_CUT}

    def ee_goal(self, ud, goal):
        phase = self._EE_PHASE.get(goal.command)
        if phase is not None:
            self.context.checkpoint.phase(phase)
        return goal

    def ee_result_then(self, command, after):
        """ee_result, and the checkpoint phase a succeeded `command` leaves: a cut fruit is off
        the plant (place); a closed valve leaves `after`."""
        phase = {EndEffectorGoal.SHEAR_CUT: checkpoint_lib.PHASE_PLACE,
                 EndEffectorGoal.SUCTION_OFF: after}.get(command)

        box = command == EndEffectorGoal.SUCTION_OFF and after == checkpoint_lib.PHASE_PLACED

        def cb(ud, status, result):
            verdict = self.ee_result(ud, status, result)
            if verdict is None and phase is not None and goals.succeeded(status):
                self.context.checkpoint.phase(phase)
                if box:
                    self.context.dropped = goals.dropped_on_the_way(result)
                    if self.context.dropped:
                        rospy.logwarn('executive: %s', self.context.dropped)
            return verdict
        return cb

    def servo_result(self, ud, status, result):
        return self._reported('DO_VISUALSERVOING', status, result)

    def _reported(self, label, status, result):
        """End effector and visual servo: the server's own message is the reason."""
        failure = goals.report_failure(status, result)
        if failure is not None:
            self.context.fail('%s: %s' % (label, failure))
            return 'aborted'
        return None

    def servo_goal(self, ud, goal):
        return goals.servo_goal(ud.target)

    # --- the pull and the look at the held fruit -----------------------------------------------
    def pull_goal(self, ud, goal):
        return goals.pull_kinematics_goal(ud.target, ud.pull)

    def pull_kinematics_result(self, ud, status, result):
        joints, reason = goals.kinematics_solution(result)
        if reason is not None:
            rospy.logwarn('executive: cannot draw the fruit out (%s); cutting it in place', reason)
            return 'unreachable'
        if joints is not None:
            ud.joint_goal = joints
        return None

    def pull_move_result(self, ud, status, result):
        verdict = self.move_result(ud, status, result)
        if verdict is None and goals.succeeded(status):
            # the held fruit moved with the suction sleeve: the left arm aims at its new place
            ud.target = goals.pulled(ud.target, ud.pull)
        return verdict

    def held_scan_goal(self, ud, goal):
        return goals.held_scan_goal(self.frame)

    def held_scan_result(self, ud, status, result):
        t = ud.target
        tomatoes = result.tomatoes.tomatoes if result is not None and result.success else None
        found = goals.relocate(t, tomatoes, self.relocate_tolerance,
                               self.relocate_radius_tolerance,
                               self.context.stereo_eye(t.pick_point.header.frame_id)
                               if self.relocate_depth else None)
        if found.why == 'not-found':
            rospy.loginfo('executive: held fruit not found again within %.0f mm; keeping its '
                          'first estimate', self.relocate_tolerance * 1e3)
        elif found.why == 'smaller':
            rospy.loginfo('executive: held fruit seen again %.1f mm from where it was expected but '
                          'smaller (radius %.1f mm, first scan %.1f mm); keeping its first estimate',
                          found.distance * 1e3, found.radius * 1e3, t.radius * 1e3)
        elif found.why == 'depth':
            rospy.loginfo('executive: held fruit seen again %.1f mm from where it was expected but '
                          'smaller (radius %.1f mm, first scan %.1f mm); its first estimate moved '
                          '%+.1f mm along the stereo head\'s view ray', found.distance * 1e3,
                          found.radius * 1e3, t.radius * 1e3, found.shift * 1e3)
            ud.target = found.target
        elif found.why == 'moved':
            rospy.loginfo('executive: held fruit located again %.1f mm from where it was expected, '
                          'radius %.1f mm (first scan %.1f mm)', found.distance * 1e3,
                          found.radius * 1e3, t.radius * 1e3)
            ud.target = found.target
        return None
