"""Crash-safe continuation of the executive, free of ROS: its checkpoint and the decision what to
do when it starts again with an unfinished mission.

The executive keeps one `CheckpointKeeper`; every transition that matters changes it and hands a
snapshot (`Snapshot`, plain values) to a publish hook (executive_node: harvest_msgs/Checkpoint on
`mission/checkpoints`, stored by database_pkg's database_node, one row per mission). A restarted
executive reads the latest unfinished one back (`get_checkpoint`) and `resume_plan` says how to make
the robot safe and where to go on.

Phases of the target being picked (Checkpoint.phase) and what the robot may be doing then:

| phase      | set when                               | fruit on the suction cup            |
|------------|----------------------------------------|-------------------------------------|
| ''         | between targets (a point, a record)    | none                                |
| approach   | a target is taken (kinematics, moves)  | none                                |
| suction    | the suction valve is commanded open    | maybe, still on its peduncle        |
| pull       | the held fruit is drawn out            | yes, still on its peduncle          |
| cut        | the shear is commanded                 | yes, cut or still on its peduncle   |
| place      | the cut succeeded (to the box)         | yes, off the plant                  |
| placed     | the valve closed over the box          | none (in the box, record not out)   |
"""

from control_pkg.mission import OUTCOME_LOST, OUTCOME_PICKED
from control_pkg.mission_planning import distance

PHASE_NONE = ''
PHASE_APPROACH = 'approach'
PHASE_SUCTION = 'suction'
PHASE_PULL = 'pull'
PHASE_CUT = 'cut'
PHASE_PLACE = 'place'
PHASE_PLACED = 'placed'
PHASES = (PHASE_NONE, PHASE_APPROACH, PHASE_SUCTION, PHASE_PULL, PHASE_CUT, PHASE_PLACE,
          PHASE_PLACED)
#: phases in which the suction valve may be open
HOLDING_PHASES = (PHASE_SUCTION, PHASE_PULL, PHASE_CUT, PHASE_PLACE)

# what a restarted executive does before it scans again (ResumePlan.steps, in order)
STEP_CUT = 'cut'                  # close the shear again where the left arm stopped
STEP_PLACE = 'place'              # left arm home, right arm over the box, suction off
STEP_RELEASE = 'release'          # suction off where the arm is
STEP_HOME = 'home'                # left arm home (waist 0), right arm home

# the record a resume writes for the fruit it was holding (ResumePlan.record)
RECORD_PICKED = OUTCOME_PICKED
RECORD_LOST = OUTCOME_LOST


class Snapshot(object):
    """One checkpoint: plain values, the fields of harvest_msgs/Checkpoint."""

    FIELDS = ('mission_id', 'robot', 'points', 'point_index', 'picking_point', 'targets_done',
              'target_id', 'target_position', 'phase', 'holding', 'finished', 'outcome')

    def __init__(self, mission_id, robot='', points=(), point_index=-1, picking_point=-1,
                 targets_done=(), target_id=-1, target_position=None, phase=PHASE_NONE,
                 holding=False, finished=False, outcome=''):
        if phase not in PHASES:
            raise ValueError('unknown checkpoint phase %r (expected one of %s)' % (phase, PHASES))
        self.mission_id = mission_id
        self.robot = robot
        self.points = [int(p) for p in points]
        self.point_index = int(point_index)
        self.picking_point = int(picking_point)
        self.targets_done = [(int(t), tuple(float(v) for v in xyz)) for t, xyz in targets_done]
        self.target_id = int(target_id)
        self.target_position = None if target_position is None else tuple(
            float(v) for v in target_position)
        self.phase = phase
        self.holding = bool(holding)
        self.finished = bool(finished)
        self.outcome = outcome

    def as_dict(self):
        return dict((k, getattr(self, k)) for k in self.FIELDS)

    def __eq__(self, other):
        return isinstance(other, Snapshot) and self.as_dict() == other.as_dict()

    def __repr__(self):
        return 'Snapshot(%r)' % (self.as_dict(), )


class CheckpointKeeper(object):
    """The executive's progress as it goes; every change calls `publish(snapshot)`.

    Transitions: point(), target(), phase(), target_done(), finish(). Thread-safety: the
    executive's states change it one at a time (the pipelined schedule's overlaps only change
    the phase, a single assignment)."""

    def __init__(self, mission_id, robot='', publish=None):
        self._publish = publish or (lambda snapshot: None)
        self.current = Snapshot(mission_id, robot)

    def _emit(self, **changes):
        values = self.current.as_dict()
        values.update(changes)
        self.current = Snapshot(**values)
        self._publish(self.current)
        return self.current

    def point(self, points, point_index):
        """At picking point points[point_index]: nothing done there yet (after a resume at this
        point, the targets done before the restart stay done: see `keep_done`)."""
        points = list(points)
        picking_point = points[point_index] if 0 <= point_index < len(points) else -1
        same = (point_index == self.current.point_index and points == self.current.points)
        return self._emit(points=points, point_index=point_index, picking_point=picking_point,
                          targets_done=self.current.targets_done if same else [],
                          target_id=-1, target_position=None, phase=PHASE_NONE, holding=False)

    def target(self, target_id, position):
        return self._emit(target_id=target_id, target_position=position, phase=PHASE_APPROACH,
                          holding=False)

    def phase(self, phase):
        """The current target entered `phase` (holding follows from it); nothing without a
        current target (e.g. the valve closed by a resume before any target)."""
        if phase not in PHASES:
            raise ValueError('unknown checkpoint phase %r' % (phase, ))
        if self.current.target_id < 0 or self.current.finished:
            return self.current
        return self._emit(phase=phase, holding=phase in HOLDING_PHASES)

    def target_done(self, target_id, position):
        """The target's record is out: done at this point, nothing held."""
        done = list(self.current.targets_done) + [(target_id, position)]
        return self._emit(targets_done=done, target_id=-1, target_position=None,
                          phase=PHASE_NONE, holding=False)

    def restore(self, snapshot):
        """Continue from a stored checkpoint (same mission id); publishes nothing."""
        self.current = Snapshot(**snapshot.as_dict())

    def finish(self, outcome):
        return self._emit(finished=True, outcome=outcome, holding=False)


class ResumePlan(object):
    """What a restarted executive does with an unfinished checkpoint.

    steps: STEP_* in order, before it scans again; record: RECORD_* for the held fruit once the
    steps end (None: no record; `record_if_failed` when a step fails: the fruit was let go where
    it was); point_index: where the plan goes on (that point is scanned again); skip: positions
    of targets already recorded at that point (a new scan's target within `tolerance` of one is
    not tried again); why: one line for the log and the mission event."""

    def __init__(self, steps, record, record_if_failed, point_index, skip, why):
        self.steps = list(steps)
        self.record = record
        self.record_if_failed = record_if_failed
        self.point_index = point_index
        self.skip = list(skip)
        self.why = why

    def __repr__(self):
        return 'ResumePlan(%r)' % (self.__dict__, )


def _near(a, b, tolerance):
    return distance(a, b) <= tolerance


def resume_plan(snapshot, recorded=(), tolerance=0.02):
    """Decide how to continue an unfinished checkpoint (`Snapshot`).

    recorded: (picking_point, target_id, (x, y, z)) of the mission's pick records already in the
    store: a record can be out while its checkpoint was not (the process died between the two),
    so the current target counts as recorded when one of these matches it (same point and id,
    within `tolerance`), and every one at the checkpoint's point is skipped after the new scan.

    The decision, by phase (the robot is safe before anything else moves):
    - '' / approach: nothing held; suction off anyway (a valve command may have gone out
      unrecorded), arms home.
    - suction / pull: the fruit is still on its peduncle: suction off where it is (it springs
      back onto the plant), arms home; it is scanned and picked again, with one record.
    - cut: the shear was commanded and the fruit may or may not be cut; the left arm has not
      moved since (it closes the shear where it stopped): close the shear again (nothing
      happens if it was cut), then place it; a failed cut releases it (still on the plant).
    - place: off the plant: place it in the box and record it picked; if a move fails it is let
      go where it is and recorded lost (dropped).
    - placed: in the box: record it picked (unless its record is out), arms home.
    """
    if snapshot.finished:
        raise ValueError('checkpoint of mission %s is finished: nothing to resume'
                         % snapshot.mission_id)
    point = snapshot.picking_point
    skip = [tuple(xyz) for _, xyz in snapshot.targets_done]
    for rec_point, _rec_id, xyz in recorded:
        if rec_point == point and not any(_near(xyz, s, tolerance) for s in skip):
            skip.append(tuple(xyz))
    phase = snapshot.phase
    current_recorded = snapshot.target_id >= 0 and snapshot.target_position is not None and any(
        rec_point == point and rec_id == snapshot.target_id and
        _near(xyz, snapshot.target_position, tolerance)
        for rec_point, rec_id, xyz in recorded)
    index = max(snapshot.point_index, 0)
    if phase in (PHASE_NONE, PHASE_APPROACH):
        return ResumePlan([STEP_RELEASE, STEP_HOME], None, None, index, skip,
                          'no fruit held (phase %r): suction off, arms home, scan again'
                          % (phase or 'between targets'))
    if phase in (PHASE_SUCTION, PHASE_PULL):
        return ResumePlan([STEP_RELEASE, STEP_HOME], None, None, index, skip,
                          'fruit %d still on its peduncle (phase %s): released, arms home, '
                          'scan again' % (snapshot.target_id, phase))
    record = None if current_recorded else RECORD_PICKED
    failed = None if current_recorded else RECORD_LOST
    if phase == PHASE_CUT:
        return ResumePlan([STEP_CUT, STEP_PLACE, STEP_HOME], record, failed, index, skip,
                          'fruit %d held at the cut: shear closed again, placed in the box, '
                          'arms home' % snapshot.target_id)
    if phase == PHASE_PLACE:
        return ResumePlan([STEP_PLACE, STEP_HOME], record, failed, index, skip,
                          'fruit %d cut and held: placed in the box, arms home'
                          % snapshot.target_id)
    return ResumePlan([STEP_HOME], record, None, index, skip,
                      'fruit %d already in the box: recorded, arms home' % snapshot.target_id)


def not_done(targets, skip, tolerance=0.02):
    """The targets (objects with .pick_point.point) of a new scan that are not within
    `tolerance` of a position in `skip` (recorded before a restart)."""
    kept = []
    for t in targets:
        p = t.pick_point.point
        if not any(_near((p.x, p.y, p.z), s, tolerance) for s in skip):
            kept.append(t)
    return kept


def restart_detail(starts, resumed_mission=None, why=''):
    """The text of the mission event of a (re)start of the task planner."""
    text = 'task_planner restarted (start %d)' % starts
    if resumed_mission:
        text += '; continuing mission %s: %s' % (resumed_mission, why)
    else:
        text += '; no unfinished mission to continue: waiting for ~start'
    return text
