"""control_pkg.executive_states: what the executive's own states share and how a resume starts."""
from control_pkg.smach_compat import smach


def test_clear_preempts_services_every_pending_request_in_a_tree():
    # a preempt that reached a state as it finished stays pending on it; after an emergency
    # stop the mission must start again with none (else its next run ends 'preempted' at once)
    from control_pkg.executive_states import clear_preempts

    class Quick(smach.State):
        def __init__(self):
            smach.State.__init__(self, outcomes=['done'])

        def execute(self, ud):
            return 'done'

    inner = smach.StateMachine(outcomes=['done'])
    with inner:
        smach.StateMachine.add('A', Quick())
    cc = smach.Concurrence(outcomes=['done'], default_outcome='done')
    with cc:
        smach.Concurrence.add('INNER', inner)
        smach.Concurrence.add('B', Quick())
    leaf_a, leaf_b = inner.get_children()['A'], cc.get_children()['B']
    leaf_a.request_preempt()
    leaf_b.request_preempt()
    inner.request_preempt()
    clear_preempts(cc)
    assert not any(s.preempt_requested() for s in (cc, inner, leaf_a, leaf_b))
    assert inner.execute(smach.UserData()) == 'done'


def _context(records):
    from control_pkg import mission as mission_lib
    from control_pkg.executive_states import MissionContext
    recorder = mission_lib.MissionRecorder('m1')
    context = MissionContext({}, mission_lib.Progress([0]), recorder, publish_record=records.append)
    context.now = lambda: 10.0
    recorder.begin_fruit(0, 7, (0.5, 0.1, 1.0), 2.0)
    return context


def test_a_fruit_placed_with_no_vacuum_on_the_cup_is_recorded_dropped_and_counted():
    # the valve closed over the box with no vacuum (released_empty): the graph says picked,
    # the record says dropped, with why; it is off the plant either way (not tried again)
    from harvest_msgs.msg import EndEffectorResult
    from control_pkg import executive_goals as goals
    from control_pkg import mission as mission_lib
    from control_pkg.executive_states import EndFruit
    records = []
    context = _context(records)
    context.dropped = goals.dropped_on_the_way(EndEffectorResult(success=True, released_empty=True))
    assert 'vacuum lost while carrying' in context.dropped
    assert EndFruit(context, mission_lib.OUTCOME_PICKED).execute(None) == 'done'
    assert [(r.target_id, r.outcome) for r in records] == [(7, mission_lib.OUTCOME_DROPPED)]
    assert 'no vacuum' in records[0].reason
    assert context.dropped is None and 7 in context.gone
    totals = context.recorder.totals()
    assert (totals['picked'], totals['dropped']) == (0, 1)


def test_a_fruit_placed_on_vacuum_stays_picked_and_other_outcomes_ignore_the_flag():
    from harvest_msgs.msg import EndEffectorResult
    from control_pkg import executive_goals as goals
    from control_pkg import mission as mission_lib
    from control_pkg.executive_states import EndFruit
    assert goals.dropped_on_the_way(EndEffectorResult(success=True)) is None
    assert goals.dropped_on_the_way(None) is None
    records = []
    context = _context(records)
    EndFruit(context, mission_lib.OUTCOME_PICKED).execute(None)
    context.recorder.begin_fruit(0, 8, (0.6, 0.1, 1.0), 11.0)
    context.dropped = 'stale'
    context.last_error = 'beyond reach'
    EndFruit(context, mission_lib.OUTCOME_UNREACHABLE).execute(None)
    assert [(r.target_id, r.outcome, r.reason) for r in records] == [
        (7, mission_lib.OUTCOME_PICKED, ''), (8, mission_lib.OUTCOME_UNREACHABLE, 'beyond reach')]
    assert context.dropped is None


def test_do_error_leaves_a_move_the_emergency_stop_ended_to_do_stop():
    # the stop's halt can end a move (aborted) before the stop monitor ends the mission: that
    # is not a fault (no halt here, no record, no fault event); DO_STOP does all of it
    from control_pkg.executive_states import DoError
    records, events, halts = [], [], []
    context = _context(records)
    context.publish_event = lambda kind, state, detail: events.append(kind)
    context.halt = lambda: halts.append(1) or (True, 'halted')
    context.stopping = lambda: True
    assert DoError(context).execute(None) == 'aborted'
    assert (records, events, halts) == ([], [], [])
    assert context.recorder.current is not None             # the fruit is DO_STOP's to record
    context.stopping = lambda: False
    context.last_error = 'drive fault on right_boom'
    assert DoError(context).execute(None) == 'aborted'
    assert events == ['fault'] and halts == [1] and [r.outcome for r in records] == ['failed']


def _action_state(monkeypatch, context, results):
    """A HarvestActionState (retries 2) whose goals end with the given (outcome, status text)
    in turn, with no action server: the base class's execute is replaced."""
    from control_pkg import executive_states as es
    sent = []

    def execute(state, ud):
        outcome, text = results[len(sent)]
        sent.append(outcome)
        state.goal_status_text = text
        return outcome
    monkeypatch.setattr(es.SimpleActionState, 'execute', execute)
    state = es.HarvestActionState.__new__(es.HarvestActionState)
    smach.State.__init__(state, outcomes=['succeeded', 'aborted', 'preempted'])
    state._context, state._label, state._action_name = context, 'DO_MOVE_ROBOT', 'move_robot'
    state._retries, state._gate = 2, None
    return state, sent


def test_a_move_the_stop_topic_halted_takes_the_stop_here_too(monkeypatch):
    # motion_server heard /emergency_stop first and aborted the move with its stop text: the
    # executive takes the stop itself (no retry, no fault), whichever message came first
    from motion_pkg.motion_goals import ESTOP_HALT_TEXT
    context = _context([])
    stops = []
    context.request_stop = stops.append
    context.stopping = lambda: bool(stops)
    state, sent = _action_state(monkeypatch, context, [('aborted', ESTOP_HALT_TEXT)] * 3)
    assert state.execute(None) == 'aborted'
    assert sent == ['aborted'] and len(stops) == 1 and ESTOP_HALT_TEXT in stops[0]
    assert context.recorder.errors == [] and not context.last_error


def test_a_move_aborted_for_another_reason_is_retried_and_then_a_fault(monkeypatch):
    context = _context([])
    stops = []
    context.request_stop = stops.append
    state, sent = _action_state(monkeypatch, context, [('aborted', 'drive fault on right_boom')] * 3)
    assert state.execute(None) == 'aborted'
    assert sent == ['aborted'] * 3 and stops == []
    assert 'drive fault on right_boom' in context.last_error


def _stop_context(records, events, points=(0, 1)):
    """A mission at the first of `points` with target 7 open, a stop under way."""
    from control_pkg import mission as mission_lib
    from control_pkg.executive_states import MissionContext
    recorder = mission_lib.MissionRecorder('m1', same_fruit=0.03)
    context = MissionContext({}, mission_lib.Progress(list(points)), recorder,
                             publish_record=records.append,
                             publish_event=lambda kind, state, detail: events.append((kind, detail)),
                             halt=lambda: (True, 'halted'))
    clock = [10.0]
    context.now = lambda: clock[0]
    context.progress.advance()
    recorder.begin_fruit(0, 7, (0.5, 0.1, 1.0), 2.0)
    context.checkpoint.target(7, (0.5, 0.1, 1.0))
    recorder.add_state('DO_MOVE_ROBOT', 1.5)
    return context, clock


def _do_stop(context):
    import threading
    from control_pkg.executive_states import DoStop
    estop, resume = threading.Event(), threading.Event()
    estop.set()
    resume.set()                       # the operator's resume, already there: no wait
    assert DoStop(context, estop, resume).execute(None) == 'resume'
    assert not estop.is_set()


def _tomato(tid, y):
    from harvest_msgs.msg import Tomato
    t = Tomato(id=tid, radius=0.03, pickable=True)
    t.pick_point.header.frame_id = 'base_link'
    t.pick_point.point.x, t.pick_point.point.y, t.pick_point.point.z = 0.5, y, 1.0
    return t


def _next_target(context, targets):
    from control_pkg.executive_states import NextPoint, NextTarget
    ud = smach.UserData()
    ud.targets = targets
    assert NextPoint(context).execute(ud) == 'point'
    return NextTarget(context).execute(ud), ud


def test_a_fruit_the_stop_cut_short_and_picked_after_the_resume_has_one_record():
    # issue 14: no `failed` record from DO_STOP; after the resume the same point is scanned
    # again and the fruit (a new id, 5 mm away) continues its record, closed once by END_PICKED
    from control_pkg import mission as mission_lib
    from control_pkg.executive_states import EndFruit
    records, events = [], []
    context, clock = _stop_context(records, events)
    _do_stop(context)
    assert records == []
    estop = [d for k, d in events if k == 'estop']
    assert len(estop) == 1 and 'target 7 at picking point 0 interrupted' in estop[0]
    clock[0] = 60.0
    outcome, ud = _next_target(context, [_tomato(3, 0.105)])
    assert outcome == 'target' and ud.picking_point == 0         # the interrupted point again
    context.recorder.add_state('DO_MOVE_ROBOT', 2.0)
    clock[0] = 70.0
    EndFruit(context, mission_lib.OUTCOME_PICKED).execute(None)
    assert [(r.target_id, r.outcome, r.reason) for r in records] == [(3, 'picked', '')]
    rec = records[0]
    assert rec.state_names == ['DO_MOVE_ROBOT', mission_lib.STOP_STATE, 'DO_MOVE_ROBOT']
    assert rec.cycle_time == (10.0 - 2.0) + (70.0 - 60.0)        # without the pause
    totals = context.recorder.totals()
    assert (totals['attempted'], totals['picked'], totals['failed'], totals['interrupted']) == \
        (1, 1, 0, 1)


def test_a_fruit_the_stop_cut_short_that_is_gone_after_the_resume_is_failed_once():
    # not in the new scan (the shear may have cut it; the scan may miss it): `failed`
    # (interrupted) once the mission leaves its point, and the summary counts it once
    from control_pkg import mission as mission_lib
    records, events = [], []
    context, clock = _stop_context(records, events)
    _do_stop(context)
    outcome, ud = _next_target(context, [])
    assert outcome == 'done' and records == []                  # its point may still show it
    _next_target(context, [])                                   # on to picking point 1
    assert [(r.target_id, r.outcome) for r in records] == [(7, mission_lib.OUTCOME_FAILED)]
    assert records[0].reason.startswith(mission_lib.INTERRUPTED)
    assert records[0].cycle_time == 8.0
    totals = context.recorder.totals()
    assert (totals['attempted'], totals['failed'], totals['interrupted']) == (1, 1, 1)


def test_a_fruit_already_in_the_box_when_the_stop_came_is_recorded_picked():
    from control_pkg import checkpoint as checkpoint_lib
    from control_pkg import mission as mission_lib
    records, events = [], []
    context, clock = _stop_context(records, events)
    context.checkpoint.phase(checkpoint_lib.PHASE_PLACED)       # the valve closed over the box
    _do_stop(context)
    assert [(r.target_id, r.outcome) for r in records] == [(7, mission_lib.OUTCOME_PICKED)]
    assert context.recorder.interrupted == [] and 'interrupted' not in context.recorder.totals()
    assert context.checkpoint.current.target_id == -1           # done: not tried again


def test_a_fruit_cut_and_held_when_the_stop_came_is_recorded_failed_at_once():
    # off the plant, it cannot be tried again: failed now, and a target of the new scan 1 cm
    # away (the mock's spacing) is another fruit
    from control_pkg import checkpoint as checkpoint_lib
    from control_pkg import mission as mission_lib
    records, events = [], []
    context, clock = _stop_context(records, events)
    context.checkpoint.phase(checkpoint_lib.PHASE_PLACE)
    _do_stop(context)
    assert [(r.target_id, r.outcome) for r in records] == [(7, mission_lib.OUTCOME_FAILED)]
    assert records[0].reason.startswith(mission_lib.INTERRUPTED)
    assert records[0].state_names == ['DO_MOVE_ROBOT', mission_lib.STOP_STATE]
    assert 'recorded failed' in [d for k, d in events if k == 'estop'][0]
    assert context.checkpoint.current.phase == checkpoint_lib.PHASE_PLACE  # a restart places it
    _next_target(context, [_tomato(8, 0.11)])
    assert context.recorder.current.target_id == 8 and context.recorder.current.attempts == 1


def test_the_stereo_eye_comes_from_the_robot_geometry_and_turns_with_the_waist():
    import math
    import os
    import pytest
    from motion_pkg.kinematics import RobotGeometry
    context = _context([])
    assert context.stereo_eye() is None, 'no geometry: no eye (the held fruit keeps its estimate)'
    context.geometry = RobotGeometry.from_yaml(os.path.join(
        os.path.dirname(__file__), '..', '..', 'harvest_description', 'config', 'robot.yaml'))
    head = context.geometry.stereo_xyz                  # waist_link -> stereo_link (right eye)
    assert context.stereo_eye() == pytest.approx(head), 'waist unknown: at 0'
    assert context.stereo_eye('base_link') == pytest.approx(head)
    assert context.stereo_eye('map') is None, 'the cart moves in map: no eye'
    assert context.stereo_eye('odom') is None, 'a frame the geometry does not have: no eye'
    context.set_joints(['waist_joint'], [0.5])
    c, s = math.cos(0.5), math.sin(0.5)
    assert context.stereo_eye() == pytest.approx(
        (c * head[0] - s * head[1], s * head[0] + c * head[1], head[2]))
