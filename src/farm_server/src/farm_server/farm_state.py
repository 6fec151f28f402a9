"""The fused farm state: per-point expected ripe fruit, the fruit report, plans and yields.

Pure Python; ``FarmState`` is what ``fusion.fuse()`` returns (see the ``fusion`` docstring).
"""

import collections

from farm_server.fusion_config import (DAY, OUTCOME_NAMES, OUTCOME_PICKED, day_of,
                                       day_start)


class FarmState(object):
    """Result of ``fuse()``: rows of points and fruit, and the harvest records."""

    def __init__(self, cfg, until, rows, missions, picks, unmatched_picks, skipped):
        self.cfg = cfg
        self.until = until
        self.rows = rows                    # name -> _Row
        self.missions = missions            # list of dicts (robot, mission_id, site, start)
        self.picks = picks                  # list of dicts (robot, row, outcome, cycle_time, t)
        self.unmatched_picks = unmatched_picks
        self.skipped = skipped              # sightings without a usable map position

    # ------------------------------------------------------------------ per point

    def expected_ripe(self, row, t):
        """{picking_point: number of present fruit forecast ripe at time t}."""
        out = dict((k, 0) for k in self.rows[row].points) if row in self.rows else {}
        if row not in self.rows:
            return out
        for fruit in self.rows[row].fruits:
            if fruit.status == 'present' and fruit.point is not None and \
                    fruit.forecast(t) >= self.cfg.ripe_score:
                out[fruit.point] += 1
        return out

    def point_table(self, row, t):
        """Per picking point of a row: position, fruit present, forecast ripe at t, last scan."""
        if row not in self.rows:
            return []
        r = self.rows[row]
        ripe = self.expected_ripe(row, t)
        present = dict((k, 0) for k in r.points)
        for fruit in r.fruits:
            if fruit.status == 'present' and fruit.point is not None:
                present[fruit.point] += 1
        out = []
        for k, p in r.points.items():
            if not p.positions:
                continue
            out.append(dict(picking_point=k, track_position=round(p.track_position, 4),
                            expected_ripe=ripe[k], fruit_present=present[k],
                            last_scan=p.last_scan, scans=len(p.scans),
                            unlocalised=p.unlocalised))
        out.sort(key=lambda d: (d['track_position'], d['picking_point']))
        return out

    def fruits(self, row, t, picking_point=None):
        """Fruit of a row grouped by picking point and plant, with histories and forecasts."""
        if row not in self.rows:
            return []
        cfg = self.cfg
        groups = {}
        for fruit in self.rows[row].fruits:
            if picking_point is not None and fruit.point != picking_point:
                continue
            ready = fruit.ready_at(cfg.ripe_score)
            entry = dict(
                fruit_id=fruit.fruit_id, status=fruit.status,
                position=[round(c, 4) for c in fruit.position],
                rate_per_day=round(fruit.rate, 4), rate_fitted=fruit.fitted,
                forecast_score=round(fruit.forecast(t), 4),
                ready_at=ready, ready_day=day_of(ready, cfg).isoformat() if ready else None,
                harvested_at=fruit.harvested_at, harvested_by=fruit.harvested_by,
                history=[dict(t=h[0], day=day_of(h[0], cfg).isoformat(), score=h[1],
                              stage=h[2], robot=h[3], mission_id=h[4], picking_point=h[5])
                         for h in fruit.history])
            groups.setdefault(fruit.point, {}).setdefault(fruit.plant(cfg), []).append(entry)
        out = []
        for k in sorted(groups, key=lambda v: (v is None, v)):
            plants = [dict(plant=pl, fruits=groups[k][pl]) for pl in sorted(groups[k])]
            out.append(dict(picking_point=k, plants=plants))
        return out

    # ------------------------------------------------------------------ robots and rows

    def robot_row(self, robot):
        """The row of the robot's latest mission (by start time), or None."""
        mine = [m for m in self.missions if m['robot'] == robot]
        if not mine:
            return None
        return max(mine, key=lambda m: m['start'])['row']

    def plan(self, robot, day, row=None):
        """The day's plan for ``robot`` (dict), or None when the robot has no data yet."""
        cfg = self.cfg
        row = row or self.robot_row(robot)
        if row is None or row not in self.rows:
            return None
        t = day_start(day, cfg)
        points = []
        for p in self.point_table(row, t):
            reasons = []
            if p['expected_ripe'] >= cfg.min_expected and p['expected_ripe'] > 0:
                reasons.append('ripe')
            if cfg.revisit_days > 0 and p['last_scan'] is not None and \
                    t - p['last_scan'] >= cfg.revisit_days * DAY:
                reasons.append('revisit')
            if reasons:
                p = dict(p, reasons=reasons)
                points.append(p)
        return dict(robot=robot, row=row, day=day.isoformat(), start_of_work=t,
                    picking_points=[p['picking_point'] for p in points], points=points,
                    expected_ripe=sum(p['expected_ripe'] for p in points))

    def yields(self, day=None):
        """Harvest figures per robot and per row (all time, and on ``day`` if given)."""
        cfg = self.cfg
        robots, rows = {}, {}
        for p in self.picks:
            r = robots.setdefault(p['robot'], dict(robot=p['robot'], attempts=0, picked=0,
                                                   picked_today=0, cycle_times=[],
                                                   outcomes=dict((n, 0) for n in
                                                                 OUTCOME_NAMES.values())))
            w = rows.setdefault(p['row'], dict(row=p['row'], picked=0, picked_today=0,
                                               attempts=0))
            r['attempts'] += 1
            w['attempts'] += 1
            r['outcomes'][OUTCOME_NAMES.get(p['outcome'], 'failed')] += 1
            if p['outcome'] == OUTCOME_PICKED:
                today = day is not None and day_of(p['t'], cfg) == day
                r['picked'] += 1
                w['picked'] += 1
                r['picked_today'] += int(today)
                w['picked_today'] += int(today)
                r['cycle_times'].append(p['cycle_time'])
        missions = collections.Counter(m['robot'] for m in self.missions)
        for r in robots.values():
            times = r.pop('cycle_times')
            r['mean_cycle_time'] = round(sum(times) / len(times), 3) if times else None
            r['success_rate'] = round(r['picked'] / float(r['attempts']), 3)
            r['missions'] = missions[r['robot']]
        for robot, count in missions.items():
            robots.setdefault(robot, dict(
                robot=robot, attempts=0, picked=0, picked_today=0, mean_cycle_time=None,
                success_rate=None, outcomes=dict((n, 0) for n in OUTCOME_NAMES.values()),
                missions=count))
        return (sorted(robots.values(), key=lambda r: r['robot']),
                sorted(rows.values(), key=lambda r: r['row']))

