"""Mission bookkeeping for the executive, free of ROS: picking-point progress and the mission record.

The record keeps, per fruit, the time spent in each state and the outcome (picked, unreachable,
lost, failed with reason), one record per fruit even when an emergency stop cut an attempt short,
and per run the totals that `make demo` prints.

This module holds the progress over the picking points (`Progress`) and re-exports the rest, so
`control_pkg.mission` stays the one name to import:
- mission_record.py: the outcomes, the per-fruit record, the recorder, the summary, the mission id;
- mission_planning.py: the choice of pull and the pipelined schedule's collision check.
"""
from control_pkg.mission_planning import (  # noqa: F401 - re-exported
    distance, choose_pull, SCHEDULE_PAPER, SCHEDULE_PIPELINED, SCHEDULES, trapezoid_position,
    arm_path, _segments_distance_2d, arm_segments, thin_path, arms_min_distance, OverlapVerdict,
    START_TOLERANCE, overlap_clear, WAIST_TOLERANCE, without_waist, schedule_step)
from control_pkg.mission_record import (  # noqa: F401 - re-exported
    OUTCOME_NAMES, OUTCOME_CODES, OUTCOME_PICKED, OUTCOME_UNREACHABLE, OUTCOME_LOST,
    OUTCOME_FAILED, OUTCOME_DROPPED, OUTCOMES, STOP_STATE, INTERRUPTED, FruitRecord,
    MissionRecorder, finite_or_none, _strict, summary_json, make_mission_id, summary_line)


class Progress(object):
    """Which picking point the mission is at; survives an emergency stop and a resume.

    `points` is the ordered list of picking-point indices to visit. `advance()` moves to the next
    one; after a resume the current point is visited again (re-scanned), so the interrupted target,
    still hanging, is the first one picked.
    """

    def __init__(self, points=None, loader=None):
        """Either the `points` list now, or a `loader()` returning it at the first advance()."""
        self.points = None
        self._loader = loader
        if points is not None:
            self._set(points)
        elif loader is None:
            raise ValueError('Progress needs picking points or a loader')
        self.index = -1          # index into self.points of the current point, -1 before the first
        self.interrupted = False

    def _set(self, points):
        points = list(points)
        for p in points:
            if not isinstance(p, int) or isinstance(p, bool) or p < 0:
                raise ValueError('picking points must be non-negative integers, got %r' % (p,))
        self.points = points

    def advance(self):
        """Return the next picking point to visit, or None when the mission is complete."""
        if self.points is None:
            self._set(self._loader())
        if self.interrupted:
            self.interrupted = False
            if 0 <= self.index < len(self.points):
                return self.points[self.index]
        self.index += 1
        if self.index < len(self.points):
            return self.points[self.index]
        return None

    def current(self):
        if self.points is not None and 0 <= self.index < len(self.points):
            return self.points[self.index]
        return None

    def mark_interrupted(self):
        self.interrupted = True

    def resume_at(self, points, index):
        """Continue a plan after a restart of the executive: the next advance() returns
        points[index] again (scanned again), then the points after it."""
        self._set(points)
        if not 0 <= int(index) <= len(self.points):
            raise ValueError('resume index %r outside the plan of %d points' % (index, len(self.points)))
        self.index = int(index)
        self.interrupted = True
