"""A fruit matched across scans: its sightings and the linear ripening model fitted to them.

Pure Python; the model is described in the ``fusion`` module docstring.
"""

from farm_server.fusion_config import DAY


class Fruit(object):
    __slots__ = ('fruit_id', 'row', 'position', 'history', 'status', 'harvested_at',
                 'harvested_by', 'point', 'last_scan', 'rate', 's_ref', 't_ref', 'fitted')

    def __init__(self, fruit_id, row, position):
        self.fruit_id = fruit_id
        self.row = row
        self.position = position
        self.history = []           # (t, score, stage, robot, mission_id, picking_point)
        self.status = 'present'
        self.harvested_at = None
        self.harvested_by = None
        self.point = None
        self.last_scan = None
        self.rate = self.s_ref = self.t_ref = None
        self.fitted = False

    @property
    def last_seen(self):
        return self.history[-1][0]

    def fit(self, cfg):
        """The linear ripening model (module docstring)."""
        ts = [h[0] / DAY for h in self.history]
        ss = [h[1] for h in self.history]
        span = ts[-1] - ts[0]
        if len(ts) >= 2 and span >= cfg.min_fit_span_days:
            tm = sum(ts) / len(ts)
            sm = sum(ss) / len(ss)
            var = sum((t - tm) ** 2 for t in ts)
            slope = sum((t - tm) * (s - sm) for t, s in zip(ts, ss)) / var
            self.rate = min(max(slope, cfg.min_rate), cfg.max_rate)
            self.fitted = True
        else:
            self.rate = cfg.default_rate
            self.fitted = False
        self.s_ref, self.t_ref = ss[-1], self.history[-1][0]

    def forecast(self, t):
        """Ripeness score expected at Unix time t (not before the last sighting)."""
        t = max(t, self.last_seen)
        return self.s_ref + self.rate * (t - self.t_ref) / DAY

    def ready_at(self, ripe_score):
        """Unix time at which the forecast reaches ``ripe_score``."""
        if self.forecast(self.last_seen) >= ripe_score:
            return self.last_seen
        if self.rate <= 0.0:
            return None
        return self.t_ref + (ripe_score - self.s_ref) / self.rate * DAY

    def plant(self, cfg):
        return int(round(self.position[1] / cfg.plant_spacing))

