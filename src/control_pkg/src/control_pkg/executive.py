"""The task-planning executive: the hierarchical, concurrent state machine of continuous picking.

Section 3.4.2 of the paper, Figure 14. Every module is driven through an actionlib
SimpleActionState; the ten state labels of the paper name the states:

ROOT (StateMachine)
  RUN (Concurrence)                      the mission, watched by the emergency-stop monitor
    MISSION (StateMachine)
      WAIT_CART                          a cart move still running (not this mission's) ends first
      DO_START                           Start.action: self-test of every component
      PARK_ARMS                          left arm home, right arm over the box (DO_MOVE_ROBOT)
      NEXT_POINT                         next picking point of the plan, or mission complete
      DO_MOVEBASE                        MoveBase.action: cart to the picking point
      SCAN (Concurrence)
        DO_TOMATO_SCAN                   TomatoScan.action: pickable tomatoes, in picking order
        DO_SPATIAL_TEMPORAL              SpatialTemporal.action: observations into the database
      NEXT_TARGET                        next target of the planned order, or next point
      PICK_TARGET (StateMachine)         one tomato
        RIGHT_ARM: DO_KINEMATICS -> DO_MOVE_ROBOT -> DO_MOVE_ENDEFFECTOR (suction on)
                   -> CHOOSE_PULL -> DO_KINEMATICS_PULL -> DO_MOVE_ROBOT_PULL (draw the held fruit
                   out of its cluster, clear of the other fruit, so the left arm's camera and
                   shear can get at it; `right_pulls`)
                   -> DO_TOMATO_SCAN_HELD (the stereo head locates the presented fruit again,
                   now clear of the leaves and fruit that hid part of it)
        LEFT_ARM:  DO_KINEMATICS -> DO_MOVE_ROBOT -> DO_VISUALSERVOING -> DO_MOVE_ENDEFFECTOR (cut)
        (DO_KINEMATICS_CUT: with `check_cut_before_suction`, the cutting hand is solved first
        and a fruit it cannot reach is skipped before the suction arm moves)
        PLACE:     DO_MOVE_ROBOT (left arm home) -> DO_MOVE_ROBOT_BOX (right arm to the box)
                   -> DO_MOVE_ENDEFFECTOR (suction off)
        RECOVER:   DO_MOVE_ENDEFFECTOR (suction off) -> PARK_ARMS (DO_MOVE_ROBOT: left arm home,
                   waist 0 -> DO_MOVE_ROBOT_BOX: right arm over the box)
      DO_ERROR                           halt every axis, record the reason; mission aborted
    ESTOP_MONITOR                        ends when an emergency stop is requested
  DO_STOP                                emergency stop: axes halted, mission paused until resume

That is `schedule: paper` (the default); `schedule: pipelined` replaces RIGHT_ARM, LEFT_ARM and
PLACE with versions where the arms overlap (executive_pipelined.py, a subclass of `_Graph`).

This module only builds that graph, top-down, one container per function. The states of our
own are in executive_states.py, the goals and the reading of results in executive_goals.py
(pure, unit-tested), the plan and the record in mission.py; `_Callbacks` (executive_callbacks.py,
re-exported here) is the glue between userdata, those pure functions and the mission's shared
object (executive_states.MissionContext).
"""
from harvest_msgs.msg import (StartAction, MoveBaseAction, TomatoScanAction,
                              SpatialTemporalAction, KinematicsAction, MoveRobotAction,
                              EndEffectorAction, EndEffectorGoal, VisualServoAction)
from control_pkg.smach_compat import smach
from control_pkg import checkpoint as checkpoint_lib
from control_pkg import executive_goals as goals
from control_pkg import mission as mission_lib
from control_pkg.executive_callbacks import _Callbacks
from control_pkg.executive_states import (CartAtRest, HarvestActionState, NextPoint, NextTarget,
                                          ChoosePull, EndFruit, DoError, EstopMonitor, DoStop,
                                          Decide, ResumeRecord)

ARM_RIGHT = goals.ARM_RIGHT
ARM_LEFT = goals.ARM_LEFT
_ARM_OUTCOMES = ['succeeded', 'unreachable', 'lost', 'aborted', 'preempted']


def build_state_machine(context, estop_event, resume_event):
    """Build the ROOT state machine. `context.config` is a dict (see config/executive.yaml);
    its `schedule` chooses the graph of one target: `paper` (Figure 14, this module) or
    `pipelined` (the arms overlap, executive_pipelined.py)."""
    if context.config['schedule'] == mission_lib.SCHEDULE_PIPELINED:
        from control_pkg.executive_pipelined import PipelinedGraph
        g = PipelinedGraph(context)
    else:
        g = _Graph(context)
    monitor = EstopMonitor(estop_event)
    run = smach.Concurrence(outcomes=['succeeded', 'aborted', 'preempted', 'estop'],
                            default_outcome='aborted', child_termination_cb=lambda outcomes: True,
                            outcome_cb=_run_outcome)
    with run:
        # whichever ends first (mission or emergency stop) ends the other
        smach.Concurrence.add('MISSION', g.mission())
        smach.Concurrence.add('ESTOP_MONITOR', monitor)
    root = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'])
    with root:
        smach.StateMachine.add('RUN', run, transitions={'estop': 'DO_STOP'})
        smach.StateMachine.add('DO_STOP', DoStop(context, estop_event, resume_event, resumed=run),
                               transitions={'resume': 'RUN', 'shutdown': 'preempted'})
    root.estop_monitor = monitor
    return root


def _run_outcome(outcomes):
    if outcomes.get('ESTOP_MONITOR') == 'estop':
        return 'estop'
    if outcomes.get('MISSION') in ('succeeded', 'preempted'):
        return outcomes['MISSION']
    return 'aborted'


def _scan_outcome(outcomes):
    if 'preempted' in outcomes.values():
        return 'preempted'
    if 'aborted' in (outcomes.get('DO_TOMATO_SCAN'), outcomes.get('DO_SPATIAL_TEMPORAL')):
        return 'aborted'
    return 'none' if outcomes.get('DO_TOMATO_SCAN') == 'none' else 'targets'


class _Graph(object):
    """The containers of Figure 14, each built by one method, top-down."""
    #: userdata PICK_TARGET reads from MISSION
    pick_keys = ('target',)
    #: actions whose goals move an arm: they take turns through `gate` when there is one
    gated = ('move_robot', 'visual_servo')

    def __init__(self, context, callbacks=None):
        self.context = context
        self.cfg = context.config
        self.cb = callbacks or _Callbacks(context)
        self.gate = None
        self.pulls = [tuple(float(v) for v in p) for p in self.cfg['right_pulls']]
        self.relocate = float(self.cfg['relocate_tolerance']) > 0.0
        self.check_cut = bool(self.cfg['check_cut_before_suction'])

    def action(self, label, key, spec, arm=None, **kwargs):
        """An action state of `key` (config `actions`); `arm`: the arm its goal moves, if any."""
        cfg = self.cfg
        if self.gate is not None and key in self.gated:
            kwargs.update(gate=self.gate, gate_arm='left' if arm == ARM_LEFT else 'right')
        return HarvestActionState(self.context, label, cfg['actions'][key], spec,
                                  retries=cfg['retries'].get(key, 0),
                                  exec_timeout=cfg['timeouts'][key],
                                  server_wait_timeout=cfg['server_wait_timeout'], **kwargs)

    def end_effector(self, command, after=checkpoint_lib.PHASE_PLACED):
        """after: the checkpoint phase once the valve has closed (SUCTION_OFF): placed (in the
        box) or approach (let go: back on the plant)."""
        return self.action('DO_MOVE_ENDEFFECTOR', 'end_effector', EndEffectorAction,
                           goal=EndEffectorGoal(command=command), goal_cb=self.cb.ee_goal,
                           result_cb=self.cb.ee_result_then(command, after))

    def move_fixed(self, label, arm, positions):
        return self.action(label, 'move_robot', MoveRobotAction, arm=arm,
                           goal=goals.move_goal(arm, positions), result_cb=self.cb.move_result)

    def add_reach(self, suffix, goal_cb, result_cb, arm, then, unreachable, keys=('target',),
                  move_result_cb=None, move_keys=(), move_out=(), phase=None, solved=None):
        """DO_KINEMATICS<suffix> -> DO_MOVE_ROBOT<suffix>: solve an arm's joints, then move it
        (`solved`: the state the solution goes to instead, which leads to the move)."""
        smach.StateMachine.add('DO_KINEMATICS' + suffix, self.action(
            'DO_KINEMATICS', 'kinematics', KinematicsAction, goal_cb=goal_cb,
            input_keys=list(keys), output_keys=['joint_goal'], result_cb=result_cb,
            outcomes=['unreachable']),
            transitions={'succeeded': solved or 'DO_MOVE_ROBOT' + suffix,
                         'unreachable': unreachable})
        smach.StateMachine.add('DO_MOVE_ROBOT' + suffix, self.action(
            'DO_MOVE_ROBOT', 'move_robot', MoveRobotAction, arm=arm,
            goal_cb=self.cb.move_goal(arm, phase=phase),
            input_keys=['joint_goal'] + list(move_keys), output_keys=list(move_out),
            result_cb=move_result_cb or self.cb.move_result),
            transitions={'succeeded': then})

    # --- the mission ---------------------------------------------------------------------------
    def mission(self):
        c, cb = self.context, self.cb
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'])
        sm.userdata.picking_point = -1
        sm.userdata.track_position = 0.0
        sm.userdata.targets = []
        sm.userdata.target = None
        add = smach.StateMachine.add
        with sm:
            # no arm moves while the cart does: a cart move still running (a restarted task
            # planner's predecessor's, a manual one) ends before the first arm goal
            add('WAIT_CART', CartAtRest(c, self.cfg['actions']['move_base'] + '/status',
                                        self.cfg['cart_wait']),
                transitions={'at_rest': 'RESUME_CHECK', 'error': 'DO_ERROR'})
            # a restarted task planner continuing a mission makes the robot safe first
            add('RESUME_CHECK', Decide(cb.resume_check, ['resume', 'start']),
                transitions={'resume': 'RESUME', 'start': 'DO_START'})
            add('RESUME', self.resume(), transitions={'succeeded': 'DO_START', 'aborted': 'DO_ERROR'})
            add('DO_START', self.action('DO_START', 'self_test', StartAction,
                                        goal_cb=cb.start_goal, result_cb=cb.start_result),
                transitions={'succeeded': 'PARK_ARMS', 'aborted': 'DO_ERROR'})
            # the cart never moves with an arm out: before the first DO_MOVEBASE the arms go
            # where every point leaves them (the cutting hand home, the waist at 0, the suction
            # arm over the box, on the cart), wherever they stood at start
            add('PARK_ARMS', self.park(),
                transitions={'succeeded': 'NEXT_POINT', 'aborted': 'DO_ERROR'})
            add('NEXT_POINT', NextPoint(c),
                transitions={'point': 'DO_MOVEBASE', 'done': 'succeeded', 'error': 'DO_ERROR'})
            add('DO_MOVEBASE', self.action(
                'DO_MOVEBASE', 'move_base', MoveBaseAction, goal_cb=cb.movebase_goal,
                input_keys=['picking_point'], output_keys=['track_position'],
                result_cb=cb.movebase_result),
                transitions={'succeeded': 'SCAN', 'aborted': 'DO_ERROR'})
            add('SCAN', self.scan(),
                transitions={'targets': 'NEXT_TARGET', 'none': 'NEXT_POINT', 'aborted': 'DO_ERROR'})
            add('NEXT_TARGET', NextTarget(c),
                transitions={'target': 'PICK_TARGET', 'done': 'NEXT_POINT'})
            add('PICK_TARGET', self.pick_target(), transitions={
                'picked': 'END_PICKED', 'unreachable': 'END_UNREACHABLE', 'lost': 'END_LOST',
                'aborted': 'DO_ERROR'})
            for outcome in (mission_lib.OUTCOME_PICKED, mission_lib.OUTCOME_UNREACHABLE,
                            mission_lib.OUTCOME_LOST):
                add('END_' + outcome.upper(), EndFruit(c, outcome),
                    transitions={'done': 'NEXT_TARGET'})
            add('DO_ERROR', DoError(c), transitions={'aborted': 'aborted'})
        return sm

    def scan(self):
        cb = self.cb
        cc = smach.Concurrence(outcomes=['targets', 'none', 'aborted', 'preempted'],
                               default_outcome='aborted',
                               input_keys=['picking_point', 'track_position'],
                               output_keys=['targets'], outcome_cb=_scan_outcome)
        cc.userdata.targets = []
        with cc:
            smach.Concurrence.add('DO_TOMATO_SCAN', self.action(
                'DO_TOMATO_SCAN', 'tomato_scan', TomatoScanAction, goal_cb=cb.scan_goal,
                input_keys=['picking_point'], output_keys=['targets'],
                result_cb=cb.scan_result, outcomes=['none']))
            smach.Concurrence.add('DO_SPATIAL_TEMPORAL', self.action(
                'DO_SPATIAL_TEMPORAL', 'spatial_temporal', SpatialTemporalAction,
                goal_cb=cb.st_goal, input_keys=['picking_point', 'track_position']))
        return cc

    # --- one target ----------------------------------------------------------------------------
    def pick_target(self):
        sm = smach.StateMachine(outcomes=['picked', 'unreachable', 'lost', 'aborted', 'preempted'],
                                input_keys=list(self.pick_keys))
        add = smach.StateMachine.add
        with sm:
            if self.check_cut:
                # both arms solved before suction: a fruit the cutting hand cannot reach where it
                # hangs is skipped before the suction arm touches it (`check_cut_before_suction`)
                add('DO_KINEMATICS_CUT', self.action(
                    'DO_KINEMATICS', 'kinematics', KinematicsAction, goal_cb=self.cb.cut_check_goal,
                    input_keys=['target'], result_cb=self.cb.cut_check_result,
                    outcomes=['unreachable']),
                    transitions={'succeeded': 'RIGHT_ARM', 'unreachable': 'unreachable'})
            add('RIGHT_ARM', self.right_arm(), transitions={
                'succeeded': 'LEFT_ARM', 'unreachable': self.right_unreachable,
                'lost': 'RECOVER_LOST'})
            add('LEFT_ARM', self.left_arm(), transitions={
                'succeeded': 'PLACE', 'unreachable': 'RECOVER_UNREACHABLE', 'lost': 'RECOVER_LOST'})
            add('PLACE', self.place(), transitions={'succeeded': 'picked'})
            add('RECOVER_LOST', self.recover(), transitions={'succeeded': 'lost'})
            add('RECOVER_UNREACHABLE', self.recover(), transitions={'succeeded': 'unreachable'})
            self.add_pick_states()
        return sm

    #: where PICK_TARGET goes when the suction arm cannot reach its target (nothing moved yet)
    right_unreachable = 'unreachable'

    def add_pick_states(self):
        """More states of PICK_TARGET (a schedule's own); none in the paper's flow."""

    def right_arm(self):
        cb = self.cb
        sm = smach.StateMachine(outcomes=list(_ARM_OUTCOMES), input_keys=['target'],
                                output_keys=['target'])
        sm.userdata.joint_goal = []
        sm.userdata.pull = (0.0, 0.0, 0.0)
        with sm:
            self.add_reach('', cb.suction_goal, cb.kinematics_result, ARM_RIGHT,
                           then='DO_MOVE_ENDEFFECTOR', unreachable='unreachable')
            smach.StateMachine.add(
                'DO_MOVE_ENDEFFECTOR', self.end_effector(EndEffectorGoal.SUCTION_ON),
                transitions={'aborted': 'lost',
                             'succeeded': 'CHOOSE_PULL' if self.pulls else 'succeeded'})
            if self.pulls:
                self.add_pull()
        return sm

    def add_pull(self):
        """CHOOSE_PULL -> DO_KINEMATICS_PULL -> DO_MOVE_ROBOT_PULL [-> DO_TOMATO_SCAN_HELD]."""
        cfg, cb = self.cfg, self.cb
        smach.StateMachine.add('CHOOSE_PULL', ChoosePull(
            self.context, self.pulls, float(cfg['pull_clearance']),
            float(cfg['peduncle_gap']), float(cfg['cut_clearance'])),
            transitions={'pull': 'DO_KINEMATICS_PULL', 'none': 'succeeded'})
        # a pull the arm cannot make is not an error: the fruit is cut where it hangs
        self.add_reach('_PULL', cb.pull_goal, cb.pull_kinematics_result, ARM_RIGHT,
                       then='DO_TOMATO_SCAN_HELD' if self.relocate else 'succeeded',
                       unreachable='succeeded', keys=('target', 'pull'),
                       move_result_cb=cb.pull_move_result, move_keys=('target', 'pull'),
                       move_out=('target',), phase=checkpoint_lib.PHASE_PULL)
        if self.relocate:
            # a failed look is not a fault: the left arm works with the first estimate
            smach.StateMachine.add('DO_TOMATO_SCAN_HELD', self.action(
                'DO_TOMATO_SCAN', 'tomato_scan', TomatoScanAction, goal_cb=cb.held_scan_goal,
                input_keys=['target'], output_keys=['target'], result_cb=cb.held_scan_result),
                transitions={'aborted': 'succeeded'})

    def left_arm(self):
        cb = self.cb
        sm = smach.StateMachine(outcomes=list(_ARM_OUTCOMES), input_keys=['target'])
        sm.userdata.joint_goal = []
        with sm:
            self.add_reach('', cb.cutting_goal, cb.kinematics_result, ARM_LEFT,
                           then='DO_VISUALSERVOING', unreachable='unreachable')
            smach.StateMachine.add('DO_VISUALSERVOING', self.action(
                'DO_VISUALSERVOING', 'visual_servo', VisualServoAction, arm=ARM_LEFT,
                goal_cb=cb.servo_goal,
                input_keys=['target'], result_cb=cb.servo_result),
                transitions={'succeeded': 'DO_MOVE_ENDEFFECTOR', 'aborted': 'lost'})
            smach.StateMachine.add('DO_MOVE_ENDEFFECTOR',
                                   self.end_effector(EndEffectorGoal.SHEAR_CUT))
        return sm

    def place(self):
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'])
        with sm:
            smach.StateMachine.add('DO_MOVE_ROBOT', self.move_fixed(
                'DO_MOVE_ROBOT', ARM_LEFT, self.cfg['home']['left']),
                transitions={'succeeded': 'DO_MOVE_ROBOT_BOX'})
            smach.StateMachine.add('DO_MOVE_ROBOT_BOX', self.move_fixed(
                'DO_MOVE_ROBOT', ARM_RIGHT, self.cfg['collection_box_right']),
                transitions={'succeeded': 'DO_MOVE_ENDEFFECTOR'})
            smach.StateMachine.add('DO_MOVE_ENDEFFECTOR',
                                   self.end_effector(EndEffectorGoal.SUCTION_OFF))
        return sm

    def recover(self):
        """RECOVER: suction off, then the arms parked as a placed fruit leaves them: the left arm
        home (and the waist back to 0 if the suction move turned it: the next scan sees the row
        as the plan expects), the right arm over the box. The suction arm stayed by the fruit it
        let go; parked, it is out of the plant when the cart moves on (motion_server's cart
        interlock refuses the cart otherwise), and the next target starts like every other."""
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'])
        with sm:
            smach.StateMachine.add('DO_MOVE_ENDEFFECTOR',
                                   self.end_effector(EndEffectorGoal.SUCTION_OFF,
                                                     after=checkpoint_lib.PHASE_APPROACH),
                                   transitions={'succeeded': 'PARK_ARMS'})
            smach.StateMachine.add('PARK_ARMS', self.park())
        return sm


    # --- after a restart -------------------------------------------------------------------------
    def resume(self):
        """RESUME: the robot made safe from the checkpoint of the previous run (checkpoint.py,
        `resume_plan`): the held fruit cut again and placed, or placed, or released; a fruit that
        cannot be placed is let go where it is (recorded lost); then both arms home."""
        c, cb = self.context, self.cb
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'])
        add = smach.StateMachine.add
        off = checkpoint_lib.PHASE_APPROACH
        with sm:
            add('RESUME_START', Decide(cb.resume_first, [checkpoint_lib.STEP_CUT,
                                                         checkpoint_lib.STEP_PLACE,
                                                         checkpoint_lib.STEP_RELEASE,
                                                         checkpoint_lib.STEP_HOME]),
                transitions={checkpoint_lib.STEP_CUT: 'DO_MOVE_ENDEFFECTOR_CUT',
                             checkpoint_lib.STEP_PLACE: 'RESUME_PLACE',
                             checkpoint_lib.STEP_RELEASE: 'RESUME_RELEASE',
                             checkpoint_lib.STEP_HOME: 'RESUME_HOME'})
            # a cut that fails leaves the fruit on its peduncle: let it go there
            add('DO_MOVE_ENDEFFECTOR_CUT', self.end_effector(EndEffectorGoal.SHEAR_CUT),
                transitions={'succeeded': 'RESUME_PLACE', 'aborted': 'RESUME_RELEASE'})
            add('RESUME_PLACE', self.place(),
                transitions={'succeeded': 'RESUME_RECORD', 'aborted': 'RESUME_DROP'})
            add('RESUME_RECORD', ResumeRecord(c), transitions={'done': 'RESUME_HOME'})
            add('RESUME_DROP', self.end_effector(EndEffectorGoal.SUCTION_OFF, after=off),
                transitions={'succeeded': 'RESUME_RECORD_LOST'})
            add('RESUME_RECORD_LOST', ResumeRecord(c, failed=True),
                transitions={'done': 'RESUME_HOME'})
            add('RESUME_RELEASE', self.end_effector(EndEffectorGoal.SUCTION_OFF, after=off),
                transitions={'succeeded': 'RESUME_HOME'})
            add('RESUME_HOME', self.home(), transitions={'succeeded': 'RESUME_DONE'})
            add('RESUME_DONE', Decide(cb.resume_done, ['done']), transitions={'done': 'succeeded'})
        return sm

    def park(self):
        """PARK_ARMS: the left arm home (and the waist at 0), then the right arm over the box,
        where both rest between picking points."""
        return self._left_home_then_right('DO_MOVE_ROBOT_BOX', self.cfg['collection_box_right'])

    def home(self):
        """Both arms home: the left arm (and the waist back to 0), then the right arm."""
        return self._left_home_then_right('DO_MOVE_ROBOT_RIGHT', self.cfg['home']['right'])

    def _left_home_then_right(self, right_state, right_joints):
        """The left arm home with the waist at 0, then the right arm to `right_joints` (state
        `right_state`, label DO_MOVE_ROBOT)."""
        sm = smach.StateMachine(outcomes=['succeeded', 'aborted', 'preempted'])
        with sm:
            smach.StateMachine.add('DO_MOVE_ROBOT', self.move_fixed(
                'DO_MOVE_ROBOT', ARM_LEFT, list(self.cfg['home']['left']) + [0.0]),
                transitions={'succeeded': right_state})
            smach.StateMachine.add(right_state, self.move_fixed('DO_MOVE_ROBOT', ARM_RIGHT,
                                                                right_joints))
        return sm
