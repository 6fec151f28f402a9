"""The pipelined schedule (`schedule: pipelined`): one target with the two arms overlapping.

Same states and labels as the paper's Figure 14 (executive.py), reordered so the arms work at
the same time wherever the geometry allows; SMACH Concurrence containers hold the overlaps, so
the introspection graph shows them. Before every overlap a CHECK_* state asks the collision
check of motion_pkg's kinematics (mission.overlap_clear: the arms' forearm+tool segments kept
robot.yaml's `arm_clearance` + `overlap_margin` apart over both whole paths, whatever their
timing); when it does not clear, that step runs in the paper's order.

PICK_TARGET (StateMachine)
  [DO_KINEMATICS_CUT]                      with `check_cut_before_suction`, as in the paper flow
  RIGHT_ARM: DO_KINEMATICS -> DO_MOVE_ROBOT -> DO_MOVE_ENDEFFECTOR (suction on)
             -> CHOOSE_PULL -> DO_KINEMATICS_PULL      the pull is solved, not yet made
             with `left_standby`, between DO_KINEMATICS and suction, when the cutting hand is
             not yet waiting by this target:
             LEFT_WAITING -> DO_KINEMATICS_STANDBY -> CHECK_REACH -> REACH (Concurrence)
                                   DO_MOVE_ROBOT (the suction arm to the fruit)
                                   DO_MOVE_ROBOT_STANDBY (the cutting hand to its standby)
  LEFT_ARM:  DO_KINEMATICS_AHEAD (cutting hand, at the fruit as the pull will leave it)
             -> CHECK_APPROACH -> APPROACH (Concurrence)
                                    DRAW_OUT: DO_MOVE_ROBOT_PULL -> DO_TOMATO_SCAN_HELD
                                    DO_MOVE_ROBOT (left arm to the fruit)
                                 | no pull: DO_MOVE_ROBOT
                                 | not clear: DRAW_OUT -> DO_KINEMATICS -> DO_MOVE_ROBOT (paper)
             -> DO_VISUALSERVOING -> DO_MOVE_ENDEFFECTOR (cut)
  PLACE:     [PLAN_NEXT: HAS_NEXT -> DO_KINEMATICS (suction arm at the next target of this
              point) -> DO_KINEMATICS_STANDBY (cutting hand `standby_standoff` further back than
              its approach to that target's peduncle); with `left_standby`]
             CHECK_PLACE -> PLACE_AND_PARK (Concurrence)             both arms' whole paths clear
                              DO_MOVE_ROBOT (left arm to its standby by the next target)
                              TO_BOX: DO_MOVE_ROBOT_BOX -> DO_MOVE_ENDEFFECTOR (suction off)
                                      -> DO_MOVE_ROBOT_NEXT (the next target's suction pose)
                          | PLACE_THEN_PARK          only the way to the box meets the left arm's
                              TO_BOX: DO_MOVE_ROBOT_BOX -> DO_MOVE_ENDEFFECTOR (suction off)
                              -> PARK_AND_NEXT (Concurrence)
                                   DO_MOVE_ROBOT (left arm from the cut to its standby)
                                   DO_MOVE_ROBOT_NEXT (the next target's suction pose)
                          | PLACE_AND_RETURN (Concurrence)
                              DO_MOVE_ROBOT (left arm home)
                              TO_BOX: DO_MOVE_ROBOT_BOX -> DO_MOVE_ENDEFFECTOR (suction off)
                                      -> [NEXT_AHEAD: the right arm goes for the next target
                                         of this point while the left arm is still returning]
                          | not clear: DO_MOVE_ROBOT -> DO_MOVE_ROBOT_BOX -> DO_MOVE_ENDEFFECTOR
  LEAVE_STANDBY: the suction arm cannot reach its target: a cutting hand waiting by it goes home
  RECOVER_*: as in the paper flow (suction off, PARK_ARMS)

The standby is what makes the pipelined cycle short: in the paper's flow the cutting hand goes
home and back for every fruit (about 3.3 s each way, a 3 rad boom swing), on the critical path.
Waiting by the next fruit, its approach after the pull is a few centimetres, and its way from
the cut to the standby runs beside the suction arm's way to the box and back.

Arm moves go through the mission's MoveGate: with `concurrent_arm_moves` (the default;
motion_pkg's move_robot runs one goal per arm) the two arms' moves of an overlap run at once;
without it they run one after the other and only the rest of the overlap (kinematics, the look
at the held fruit, the suction valve) runs beside a move.
"""
import rospy

from harvest_msgs.msg import (KinematicsAction, MoveRobotAction, TomatoScanAction,
                              VisualServoAction, EndEffectorGoal)
from control_pkg.smach_compat import smach
from control_pkg import executive_goals as goals
from control_pkg import mission as mission_lib
from control_pkg.executive import _Graph, _Callbacks, _ARM_OUTCOMES, ARM_LEFT, ARM_RIGHT
from control_pkg.executive_states import ChoosePull, Decide, MoveGate

add = smach.StateMachine.add
#: rad / m (joint-space distance): the cutting hand counts as at home within this
HOME_TOLERANCE = 0.01


def _both_outcome(outcomes):
    """A Concurrence of two branches: succeeded when both did; else aborted when one aborted
    (the other one then ends preempted: `_any_aborted`), else preempted."""
    values = list(outcomes.values())
    for bad in ('aborted', 'preempted'):
        if bad in values:
            return bad
    return 'succeeded'


def _any_aborted(outcomes):
    """child_termination_cb: an aborted branch ends the overlap (DO_ERROR halts the axes)."""
    return 'aborted' in outcomes.values()


def _overlap(children, gate, first, input_keys=(), output_keys=()):
    """A Concurrence of `children` ((label, state) pairs); when the arms' moves take turns
    (`gate`), the one of arm `first` goes first (its branch starts with it)."""
    cc = smach.Concurrence(outcomes=['succeeded', 'aborted', 'preempted'],
                           default_outcome='aborted', input_keys=list(input_keys),
                           output_keys=list(output_keys), outcome_cb=_both_outcome,
                           child_termination_cb=_any_aborted)
    cc.register_start_cb(lambda ud, states: gate.first(first))
    cc.register_termination_cb(lambda ud, states, outcome: gate.first(None))
    with cc:
        for label, state in children:
            smach.Concurrence.add(label, state)
    return cc


class PipelinedGraph(_Graph):
    """PICK_TARGET of the pipelined schedule; everything else is the paper's graph."""
    pick_keys = ('target', 'targets')

    def __init__(self, context):
        _Graph.__init__(self, context, _PipelinedCallbacks(context))
        if context.gate is None:
            context.gate = MoveGate(per_arm=self.cfg['concurrent_arm_moves'])
        self.gate = context.gate
        # check_cut: the suction arm waits for the cut check, so nothing is planned ahead
        self.standby = bool(self.cfg['left_standby']) and not self.check_cut
        if self.standby:
            self.right_unreachable = 'LEAVE_STANDBY'

    def add_pick_states(self):
        if not self.standby:
            return
        # nothing has moved for this target: the cutting hand may be waiting by it
        add('LEAVE_STANDBY', Decide(self.cb.left_away, ['away', 'home']),
            transitions={'away': 'DO_MOVE_ROBOT_HOME', 'home': 'unreachable'})
        add('DO_MOVE_ROBOT_HOME', self.move_fixed('DO_MOVE_ROBOT', ARM_LEFT,
                                                  self.cfg['home']['left']),
            transitions={'succeeded': 'unreachable'})

    # --- the right arm: suction, the pull solved ------------------------------------------------
    def right_arm(self):
        cb, cfg = self.cb, self.cfg
        sm = smach.StateMachine(outcomes=list(_ARM_OUTCOMES), input_keys=['target'],
                                output_keys=['target', 'pull', 'pull_goal'])
        sm.userdata.joint_goal = []
        sm.userdata.standby_goal = []
        sm.userdata.pull = (0.0, 0.0, 0.0)
        sm.userdata.pull_goal = []
        with sm:
            self.add_reach('', cb.suction_goal, cb.kinematics_result, ARM_RIGHT,
                           then='DO_MOVE_ENDEFFECTOR', unreachable='unreachable',
                           solved='LEFT_WAITING' if self.standby else None)
            if self.standby:
                self.add_reach_with_standby()
            add('DO_MOVE_ENDEFFECTOR', self.end_effector(EndEffectorGoal.SUCTION_ON),
                transitions={'aborted': 'lost',
                             'succeeded': 'CHOOSE_PULL' if self.pulls else 'succeeded'})
            if self.pulls:
                add('CHOOSE_PULL', ChoosePull(
                    self.context, self.pulls, float(cfg['pull_clearance']),
                    float(cfg['peduncle_gap']), float(cfg['cut_clearance']),
                    clear_key='pull_goal'),
                    transitions={'pull': 'DO_KINEMATICS_PULL', 'none': 'succeeded'})
                # a pull the arm cannot make is not an error: the fruit is cut where it hangs
                add('DO_KINEMATICS_PULL', self.action(
                    'DO_KINEMATICS', 'kinematics', KinematicsAction, goal_cb=cb.pull_goal,
                    input_keys=['target', 'pull'], output_keys=['pull_goal'],
                    result_cb=cb.pull_solution, outcomes=['unreachable']),
                    transitions={'unreachable': 'succeeded'})
        return sm

    def add_reach_with_standby(self):
        """After the suction arm's DO_KINEMATICS (add_reach): a cutting hand not yet waiting by
        this target (the first target of a point; PLACE sends it there for the next ones) goes
        to its standby by it while the suction arm reaches it.
        LEFT_WAITING -> DO_KINEMATICS_STANDBY -> CHECK_REACH -> REACH (Concurrence)
        | waiting already, no standby solved or not clear: DO_MOVE_ROBOT alone (add_reach's)."""
        cb = self.cb
        sm_add = smach.StateMachine.add
        sm_add('LEFT_WAITING', Decide(cb.waiting, ['waiting', 'free'], input_keys=['target']),
               transitions={'free': 'DO_KINEMATICS_STANDBY', 'waiting': 'DO_MOVE_ROBOT'})
        sm_add('DO_KINEMATICS_STANDBY', self.action(
            'DO_KINEMATICS', 'kinematics', KinematicsAction, goal_cb=cb.standby_goal_of('target'),
            input_keys=['target'], output_keys=['standby_goal'],
            result_cb=cb.solution_into('standby_goal'), outcomes=['unreachable']),
            transitions={'succeeded': 'CHECK_REACH', 'unreachable': 'DO_MOVE_ROBOT',
                         'aborted': 'DO_MOVE_ROBOT'})
        sm_add('CHECK_REACH', Decide(cb.reach_step, ['overlap', 'sequential'],
                                     input_keys=['target', 'joint_goal', 'standby_goal']),
               transitions={'overlap': 'REACH', 'sequential': 'DO_MOVE_ROBOT'})
        sm_add('REACH', _overlap(
            [('DO_MOVE_ROBOT', self.move_to(ARM_RIGHT)),
             ('DO_MOVE_ROBOT_STANDBY', self.move_to(ARM_LEFT, 'standby_goal'))],
            self.gate, 'right', input_keys=['joint_goal', 'standby_goal']),
            transitions={'succeeded': 'DO_MOVE_ENDEFFECTOR'})

    # --- the left arm: approach while the fruit is drawn out, servo, cut --------------------------
    def left_arm(self):
        cb = self.cb
        keys = ['target', 'pull', 'pull_goal']
        sm = smach.StateMachine(outcomes=list(_ARM_OUTCOMES), input_keys=keys,
                                output_keys=['target'])
        sm.userdata.joint_goal = []
        with sm:
            add('DO_KINEMATICS_AHEAD', self.action(
                'DO_KINEMATICS', 'kinematics', KinematicsAction, goal_cb=cb.cutting_goal_ahead,
                input_keys=keys, output_keys=['joint_goal'], result_cb=cb.ahead_result,
                outcomes=['unreachable', 'after_pull']),
                transitions={'succeeded': 'CHECK_APPROACH', 'unreachable': 'unreachable',
                             'after_pull': 'DRAW_OUT'})
            add('CHECK_APPROACH', Decide(cb.approach_step, ['overlap', 'sequential', 'alone'],
                                         input_keys=['joint_goal', 'pull_goal']),
                transitions={'overlap': 'APPROACH', 'sequential': 'DRAW_OUT',
                             'alone': 'DO_MOVE_ROBOT'})
            # taking turns, the pull goes first: the look at the held fruit then runs beside
            # the left arm's move
            add('APPROACH', _overlap(
                [('DRAW_OUT', self.draw_out()), ('DO_MOVE_ROBOT', self.move_to(ARM_LEFT))],
                self.gate, 'right', input_keys=keys + ['joint_goal'], output_keys=['target']),
                transitions={'succeeded': 'DO_VISUALSERVOING'})
            # not clear: the paper's order, the cutting hand solved again beside the pulled fruit
            add('DRAW_OUT', self.draw_out(), transitions={'succeeded': 'DO_KINEMATICS'})
            self.add_reach('', cb.cutting_goal, cb.kinematics_result, ARM_LEFT,
                           then='DO_VISUALSERVOING', unreachable='unreachable')
            self.add_cut()
        return sm

    def move_to(self, arm, key='joint_goal'):
        """DO_MOVE_ROBOT of `arm` to the joints in userdata `key`."""
        return self.action('DO_MOVE_ROBOT', 'move_robot', MoveRobotAction, arm=arm,
                           goal_cb=self.cb.move_goal(arm, key), input_keys=[key],
                           result_cb=self.cb.move_result)

    def draw_out(self):
        """DO_MOVE_ROBOT_PULL [-> DO_TOMATO_SCAN_HELD]: the solved pull, then the look at it."""
        cb = self.cb
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'],
                                input_keys=['target', 'pull', 'pull_goal'], output_keys=['target'])
        with sm:
            add('DO_MOVE_ROBOT_PULL', self.action(
                'DO_MOVE_ROBOT', 'move_robot', MoveRobotAction, arm=ARM_RIGHT,
                goal_cb=cb.move_goal(ARM_RIGHT, 'pull_goal'),
                input_keys=['target', 'pull', 'pull_goal'], output_keys=['target'],
                result_cb=cb.pull_move_result),
                transitions={'succeeded': 'DO_TOMATO_SCAN_HELD' if self.relocate else 'succeeded'})
            if self.relocate:
                # a failed look is not a fault: the left arm works with the first estimate
                add('DO_TOMATO_SCAN_HELD', self.action(
                    'DO_TOMATO_SCAN', 'tomato_scan', TomatoScanAction, goal_cb=cb.held_scan_goal,
                    input_keys=['target'], output_keys=['target'], result_cb=cb.held_scan_result),
                    transitions={'aborted': 'succeeded'})
        return sm

    # --- place: to the box while the left arm returns, then on to the next target ----------------
    def place(self):
        cb = self.cb
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'],
                                input_keys=['targets'])
        sm.userdata.next_goal = []
        sm.userdata.standby_goal = []
        steps = ['standby', 'box_first', 'overlap', 'sequential'] if self.standby else \
            ['overlap', 'sequential']
        with sm:
            if self.standby:
                add('PLAN_NEXT', self.plan_next(), transitions={'succeeded': 'CHECK_PLACE'})
            add('CHECK_PLACE', Decide(cb.place_step, steps,
                                      input_keys=['targets', 'next_goal', 'standby_goal']),
                transitions=dict((step, state) for step, state in (
                    ('standby', 'PLACE_AND_PARK'), ('box_first', 'PLACE_THEN_PARK'),
                    ('overlap', 'PLACE_AND_RETURN'), ('sequential', 'DO_MOVE_ROBOT'))
                    if step in steps))
            if self.standby:
                # the box goes first when the moves take turns, as below
                add('PLACE_AND_PARK', _overlap(
                    [('DO_MOVE_ROBOT', self.move_to(ARM_LEFT, 'standby_goal')),
                     ('TO_BOX', self.to_box(next_key='next_goal'))],
                    self.gate, 'right', input_keys=['targets', 'next_goal', 'standby_goal']),
                    transitions={'succeeded': 'succeeded'})
                add('PLACE_THEN_PARK', self.place_then_park(),
                    transitions={'succeeded': 'succeeded'})
            # taking turns, the box goes first: the suction valve then closes beside the left
            # arm's return
            add('PLACE_AND_RETURN', _overlap(
                [('DO_MOVE_ROBOT', self.move_fixed('DO_MOVE_ROBOT', ARM_LEFT,
                                                   self.cfg['home']['left'])),
                 ('TO_BOX', self.to_box())], self.gate, 'right', input_keys=['targets']),
                transitions={'succeeded': 'succeeded'})
            # not clear: the paper's order
            add('DO_MOVE_ROBOT', self.move_fixed('DO_MOVE_ROBOT', ARM_LEFT, self.cfg['home']['left']),
                transitions={'succeeded': 'DO_MOVE_ROBOT_BOX'})
            add('DO_MOVE_ROBOT_BOX', self.move_fixed('DO_MOVE_ROBOT', ARM_RIGHT,
                                                     self.cfg['collection_box_right']),
                transitions={'succeeded': 'DO_MOVE_ENDEFFECTOR'})
            add('DO_MOVE_ENDEFFECTOR', self.end_effector(EndEffectorGoal.SUCTION_OFF))
        return sm

    def place_then_park(self):
        """TO_BOX (DO_MOVE_ROBOT_BOX -> DO_MOVE_ENDEFFECTOR, suction off) -> PARK_AND_NEXT
        (Concurrence: the cutting hand from the cut to its standby by the next target, the
        suction arm from the box to that target's suction pose): where the two arms' ways out
        of the cut would meet, the suction arm leaves first and the cutting hand waits at the
        cut until it is away, instead of going home and back."""
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'],
                                input_keys=['targets', 'next_goal', 'standby_goal'])
        with sm:
            add('TO_BOX', self.to_box(ahead=False), transitions={'succeeded': 'PARK_AND_NEXT'})
            add('PARK_AND_NEXT', _overlap(
                [('DO_MOVE_ROBOT', self.move_to(ARM_LEFT, 'standby_goal')),
                 ('DO_MOVE_ROBOT_NEXT', self.move_to(ARM_RIGHT, 'next_goal'))],
                self.gate, 'right', input_keys=['next_goal', 'standby_goal']))
        return sm

    def plan_next(self):
        """HAS_NEXT -> DO_KINEMATICS -> DO_KINEMATICS_STANDBY: both arms solved for the next
        target of this point (the suction pose, the cutting hand's standby). Best effort: no next
        target or no solution leaves a goal empty, and PLACE returns the left arm home."""
        cb = self.cb
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'],
                                input_keys=['targets'], output_keys=['next_goal', 'standby_goal'])
        sm.userdata.next_goal = []
        sm.userdata.standby_goal = []
        with sm:
            # the goals of the last fruit's plan are cleared first: none may be taken again
            add('HAS_NEXT', Decide(cb.plan_next, ['next', 'none'], input_keys=['targets'],
                                   output_keys=['next_goal', 'standby_goal']),
                transitions={'next': 'DO_KINEMATICS', 'none': 'succeeded'})
            add('DO_KINEMATICS', self.action(
                'DO_KINEMATICS', 'kinematics', KinematicsAction, goal_cb=cb.next_suction_goal,
                input_keys=['targets'], output_keys=['next_goal'],
                result_cb=cb.solution_into('next_goal'), outcomes=['unreachable']),
                transitions={'succeeded': 'DO_KINEMATICS_STANDBY', 'unreachable': 'succeeded',
                             'aborted': 'succeeded'})
            add('DO_KINEMATICS_STANDBY', self.action(
                'DO_KINEMATICS', 'kinematics', KinematicsAction, goal_cb=cb.standby_goal_of('targets'),
                input_keys=['targets'], output_keys=['standby_goal'],
                result_cb=cb.solution_into('standby_goal'), outcomes=['unreachable']),
                transitions={'unreachable': 'succeeded', 'aborted': 'succeeded'})
        return sm

    def to_box(self, next_key=None, ahead=True):
        """DO_MOVE_ROBOT_BOX -> DO_MOVE_ENDEFFECTOR off [-> the next target's suction pose]:
        the pose in userdata `next_key` (planned and cleared with the standby), else
        NEXT_AHEAD (not with `ahead` False)."""
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'],
                                input_keys=['targets'] + ([next_key] if next_key else []))
        # check_cut: the suction arm waits for the cut check
        ahead = ahead and not self.check_cut
        with sm:
            add('DO_MOVE_ROBOT_BOX', self.move_fixed('DO_MOVE_ROBOT', ARM_RIGHT,
                                                     self.cfg['collection_box_right']),
                transitions={'succeeded': 'DO_MOVE_ENDEFFECTOR'})
            then = 'DO_MOVE_ROBOT_NEXT' if next_key else 'NEXT_AHEAD' if ahead else 'succeeded'
            add('DO_MOVE_ENDEFFECTOR', self.end_effector(EndEffectorGoal.SUCTION_OFF),
                transitions={'succeeded': then})
            if next_key:
                add('DO_MOVE_ROBOT_NEXT', self.move_to(ARM_RIGHT, next_key))
            elif ahead:
                add('NEXT_AHEAD', self.next_ahead(), transitions={'succeeded': 'succeeded'})
        return sm

    def next_ahead(self):
        """HAS_NEXT -> DO_KINEMATICS -> CHECK_NEXT -> DO_MOVE_ROBOT: the right arm to the
        suction pose of the next target of this point. Best effort: no next target, none
        reachable or not clear of the returning left arm, and the next PICK_TARGET does it."""
        cb = self.cb
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'],
                                input_keys=['targets'])
        sm.userdata.joint_goal = []
        with sm:
            add('HAS_NEXT', Decide(cb.has_next, ['next', 'none'], input_keys=['targets']),
                transitions={'next': 'DO_KINEMATICS', 'none': 'succeeded'})
            add('DO_KINEMATICS', self.action(
                'DO_KINEMATICS', 'kinematics', KinematicsAction, goal_cb=cb.next_suction_goal,
                input_keys=['targets'], output_keys=['joint_goal'], result_cb=cb.next_solution,
                outcomes=['unreachable']),
                transitions={'succeeded': 'CHECK_NEXT', 'unreachable': 'succeeded',
                             'aborted': 'succeeded'})
            add('CHECK_NEXT', Decide(cb.next_step, ['overlap', 'sequential'],
                                     input_keys=['joint_goal']),
                transitions={'overlap': 'DO_MOVE_ROBOT', 'sequential': 'succeeded'})
            add('DO_MOVE_ROBOT', self.move_to(ARM_RIGHT))
        return sm

    def add_cut(self):
        """DO_VISUALSERVOING -> DO_MOVE_ENDEFFECTOR (cut), as in the paper flow."""
        cb = self.cb
        add('DO_VISUALSERVOING', self.action(
            'DO_VISUALSERVOING', 'visual_servo', VisualServoAction, arm=ARM_LEFT,
            goal_cb=cb.servo_goal, input_keys=['target'], result_cb=cb.servo_result),
            transitions={'succeeded': 'DO_MOVE_ENDEFFECTOR', 'aborted': 'lost'})
        add('DO_MOVE_ENDEFFECTOR', self.end_effector(EndEffectorGoal.SHEAR_CUT))


class _PipelinedCallbacks(_Callbacks):
    """The pipelined schedule's goals and decisions: userdata and the arms' joint states in,
    executive_goals' and mission's pure functions out."""

    def __init__(self, context):
        _Callbacks.__init__(self, context)
        cfg = context.config
        self.home_left = tuple(float(v) for v in cfg['home']['left'])
        self.box_right = tuple(float(v) for v in cfg['collection_box_right'])
        self.margin = float(cfg['overlap_margin'])
        self.standby_standoff = float(cfg['standby_standoff'])

    # --- goals and results ---------------------------------------------------------------------
    def pull_solution(self, ud, status, result):
        joints, reason = goals.kinematics_solution(result)
        if reason is not None:
            rospy.logwarn('executive: cannot draw the fruit out (%s); cutting it in place', reason)
            ud.pull_goal = []
            return 'unreachable'
        if joints is not None:
            ud.pull_goal = joints
        return None

    def cutting_goal_ahead(self, ud, goal):
        return goals.cutting_kinematics_goal(goals.target_after_pull(ud.target, ud.pull, ud.pull_goal),
                                             self.peduncle_gap, self.approach)

    def ahead_result(self, ud, status, result):
        """Unreachable beside a fruit still to be drawn out: solve again after the pull (the
        paper's order); with no pull to come it is final."""
        joints, reason = goals.kinematics_solution(result)
        if reason is not None and ud.pull_goal:
            rospy.loginfo('executive: cutting hand not solved ahead of the pull (%s); solving it '
                          'after the pull', reason)
            return 'after_pull'
        return self.kinematics_result(ud, status, result)

    def has_next(self, ud):
        return 'next' if ud.targets else 'none'

    def plan_next(self, ud):
        """has_next(), the plan's goals emptied first."""
        ud.next_goal = []
        ud.standby_goal = []
        return self.has_next(ud)

    def next_suction_goal(self, ud, goal):
        return goals.suction_kinematics_goal(ud.targets[0])

    def standby_goal_of(self, key):
        """goal_cb: the cutting hand's standby by the target in userdata `key` (`targets`: the
        next one)."""
        def cb(ud, goal):
            target = ud.targets[0] if key == 'targets' else ud[key]
            return goals.cutting_kinematics_goal(target, self.peduncle_gap,
                                                 self.approach + self.standby_standoff)
        return cb

    def solution_into(self, key):
        """result_cb: the joints solved into userdata `key` (empty when none: 'unreachable')."""
        def cb(ud, status, result):
            joints, reason = goals.kinematics_solution(result)
            solved = [] if reason is not None or joints is None else joints
            ud[key] = solved
            return None if solved else 'unreachable'
        return cb

    def _left_at(self, joints):
        """The cutting hand rests at `joints` (within HOME_TOLERANCE, joint space)."""
        now = self.context.arm_joints('left')
        return now is not None and mission_lib.distance(now, joints) <= HOME_TOLERANCE

    def waiting(self, ud):
        """'waiting' when the cutting hand is at the standby it was sent to by this target,
        else 'free'."""
        standby = self.context.standby
        if standby is not None and standby[0] == ud.target.id and self._left_at(standby[1]):
            return 'waiting'
        return 'free'

    def left_away(self, ud):
        """'away' when the cutting hand is not at home (waiting by this target), else 'home'."""
        return 'home' if self._left_at(self.home_left) else 'away'

    def next_solution(self, ud, status, result):
        joints, reason = goals.kinematics_solution(result)
        if reason is not None or joints is None:
            return 'unreachable'      # the next PICK_TARGET records it
        ud.joint_goal = joints
        return None

    # --- the guards of the overlaps ------------------------------------------------------------
    def approach_step(self, ud):
        if not ud.pull_goal:
            return 'alone'
        return self._step('APPROACH', {'left': ud.joint_goal, 'right': ud.pull_goal})

    def reach_step(self, ud):
        step = self._step('REACH', {'left': ud.standby_goal, 'right': ud.joint_goal})
        if step == 'overlap':
            self.context.standby = (ud.target.id, tuple(ud.standby_goal))
        return step

    def place_step(self, ud):
        """'standby' when the left arm may go to its standby by the next target while the right
        arm goes to the box and then to that target's suction pose (both legs checked against
        the left arm's whole way); 'box_first' when only the first leg meets it, the right arm's
        way to the box is clear of the resting left arm and the second leg of the left arm's way
        from the cut (PLACE_THEN_PARK); else PLACE as before, the left arm home."""
        if ud.standby_goal and ud.next_goal:
            c = self.context
            left, right = c.arm_joints('left'), c.arm_joints('right')
            standby = {'left': ud.standby_goal}
            # to the box, then from the box to the next suction pose: each leg against the
            # left arm's whole way to its standby
            to_box = self._verdict({'left': left, 'right': right},
                                   dict(standby, right=self.box_right))
            on_next = None
            if to_box.clear:
                on_next = self._verdict({'left': left, 'right': self.box_right},
                                        dict(standby, right=ud.next_goal))
            clear = on_next is not None and on_next.clear
            c.recorder.note_step('STANDBY', clear)
            if clear:
                c.standby = (ud.targets[0].id, tuple(ud.standby_goal))
                c.recorder.note_step('PLACE', True)
                rospy.loginfo('executive: PLACE overlapped, the cutting hand waits by the next '
                              'target')
                return 'standby'
            blocked = to_box if on_next is None else on_next
            if on_next is None:
                # only the first leg meets the left arm's way: the suction arm goes to the box
                # while the cutting hand stays at the cut, then both go on at once
                still = self._verdict({'left': left, 'right': right},
                                      {'left': None, 'right': self.box_right})
                on_next = self._verdict({'left': left, 'right': self.box_right},
                                        dict(standby, right=ud.next_goal))
                c.recorder.note_step('BOX_FIRST', still.clear and on_next.clear)
                if still.clear and on_next.clear:
                    c.standby = (ud.targets[0].id, tuple(ud.standby_goal))
                    rospy.loginfo('executive: no standby beside the way to the box (%s): the '
                                  'suction arm goes to the box first, then the cutting hand '
                                  'to its standby by the next target', blocked.why)
                    return 'box_first'
            rospy.loginfo('executive: no standby by the next target (%s); left arm home',
                          blocked.why)
        return self._step('PLACE', {'left': self.home_left, 'right': self.box_right})

    def next_step(self, ud):
        return self._step('NEXT_AHEAD', {'left': self.home_left, 'right': ud.joint_goal})

    def _verdict(self, starts, goals_by_arm):
        """schedule_step of the arms from `starts` to `goals_by_arm` at the mission's margin."""
        c = self.context
        return mission_lib.schedule_step(c.geometry, starts, goals_by_arm, self.margin,
                                         waist=c.waist())

    def _step(self, step, goals_by_arm):
        c = self.context
        verdict = self._verdict({'left': c.arm_joints('left'), 'right': c.arm_joints('right')},
                                goals_by_arm)
        c.recorder.note_step(step, verdict.clear)
        if verdict.clear:
            rospy.loginfo('executive: %s overlapped (arms at least %.3f m apart)', step,
                          verdict.distance)
            return 'overlap'
        rospy.loginfo('executive: %s in the paper order: %s', step, verdict.why)
        return 'sequential'
