"""Per-fruit progress of the current mission from the executive's pick records and events.

Fed with plain values (the panel unpacks harvest_msgs/PickRecord and MissionEvent), no rospy.
"""
import json

from harvest_msgs.msg import PickRecord

#: the outcome names, indexed by code: PickRecord's OUTCOME_* constants (the one source) in lower
#: case without the prefix (OUTCOME_PICKED = 0 -> OUTCOMES[0] = 'picked')
_CODES = dict((getattr(PickRecord, c), c[len('OUTCOME_'):].lower())
              for c in dir(PickRecord) if c.startswith('OUTCOME_'))
OUTCOMES = tuple(_CODES[code] for code in range(len(_CODES)))


def outcome_name(code):
    """The name of a PickRecord outcome code ('outcome <code>' for one this build does not know)."""
    return OUTCOMES[code] if 0 <= code < len(OUTCOMES) else 'outcome %d' % code


class Fruit(object):
    def __init__(self, picking_point, target_id, outcome, reason, stages, cycle_time, position):
        self.picking_point = picking_point
        self.target_id = target_id
        self.outcome = outcome
        self.reason = reason
        self.stages = stages            # [(state name, seconds)] in visiting order
        self.cycle_time = cycle_time
        self.position = position

    def stage_totals(self):
        """Seconds per state name (a state visited twice is summed), in first-visit order."""
        out = []
        index = {}
        for name, secs in self.stages:
            if name in index:
                out[index[name]] = (name, out[index[name]][1] + secs)
            else:
                index[name] = len(out)
                out.append((name, secs))
        return out


class MissionStats(object):
    """Fruits, counts, stage names in first-seen order, the current state and the summary."""

    def __init__(self):
        self.reset('')

    def reset(self, mission_id):
        self.mission_id = mission_id
        self.fruits = []
        self.stage_names = []
        self.points = []
        self.state = ''
        self.detail = ''
        self.events = []
        self.summary = None

    def _mission(self, mission_id):
        if mission_id and mission_id != self.mission_id:
            self.reset(mission_id)

    def add_record(self, mission_id, picking_point, target_id, outcome, reason, state_names,
                   state_durations, cycle_time, position=(0.0, 0.0, 0.0)):
        self._mission(mission_id)
        name = outcome_name(outcome)
        stages = list(zip(state_names, [float(d) for d in state_durations]))
        for s, _ in stages:
            if s not in self.stage_names:
                self.stage_names.append(s)
        fruit = Fruit(int(picking_point), int(target_id), name, reason, stages, float(cycle_time),
                      tuple(position))
        self.fruits.append(fruit)
        return fruit

    def add_event(self, mission_id, kind, state, detail, stamp, keep=200):
        self._mission(mission_id)
        self.events.append((stamp, kind, state, detail))
        del self.events[:-keep]
        if kind == 'summary':
            try:
                self.summary = json.loads(detail)
            except ValueError:
                self.summary = {'text': detail}
        if state:
            self.state = state
            self.detail = detail
        if kind == 'state' and state == 'NEXT_POINT':
            try:
                self.points.append(int(detail.split()[-1]))
            except (ValueError, IndexError):
                pass

    def set_summary(self, text):
        try:
            self.summary = json.loads(text)
        except ValueError:
            self.summary = {'text': text}

    def counts(self):
        out = dict((o, 0) for o in OUTCOMES)
        for f in self.fruits:
            out[f.outcome] = out.get(f.outcome, 0) + 1
        return out

    def cycle_times(self):
        return [f.cycle_time for f in self.fruits]

    def mean_cycle(self, outcome='picked'):
        times = [f.cycle_time for f in self.fruits if outcome is None or f.outcome == outcome]
        return sum(times) / len(times) if times else None

    def progress_text(self):
        c = self.counts()
        parts = ['%d fruit' % len(self.fruits)]
        parts += ['%d %s' % (c[o], o) for o in OUTCOMES if c[o]]
        if self.points:
            parts.append('point %d (%d visited)' % (self.points[-1], len(self.points)))
        mean = self.mean_cycle()
        if mean is not None:
            parts.append('mean pick cycle %.1f s' % mean)
        return ', '.join(parts)
