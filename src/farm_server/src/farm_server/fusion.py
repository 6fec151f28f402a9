"""Fusion of many robots' records over many days, the ripening forecast and the day's plan.

Pure Python (no web framework, no database): ``fuse()`` takes plain dicts as read by
``FarmDB.fusion_input()``.

Rows and picking points. A mission's ``site`` names the row its robot works (one track per row;
an empty site is the row ``default``). Picking point ``k`` of a row is where robots stop to scan;
its track position is the median ``track_position`` of the scans made there.

Fruit positions. A fruit is matched across days and robots by its position in the farm (map)
frame. Observations in a map frame (``map_frames``, default ``map``) are used as they are; in a
cart frame (``cart_frames``, default ``base_link``: on the cart, x toward the row, y along the
track) the cart's ``track_position`` is added to y, since the track runs along map +y.
Observations in any other frame, or without a 3D point, cannot be matched and are only counted.

Time of a sighting: its ROS ``stamp`` when it looks like calendar time (>= ``min_calendar_stamp``,
i.e. the robot ran on wall time), else the row's ``created`` wall-clock time (simulated time).

Matching (per row, in time order). Each scan (one robot, mission and picking point) is matched
one-to-one against the fruit not yet harvested: nearest pairs first, accepted when closer than
``match_tolerance``; an unmatched sighting starts a new fruit. A fruit's position follows its
latest sighting. A successful pick record (outcome PICKED) marks the nearest fruit within the
tolerance seen before it as harvested. A fruit not seen by a later scan of its own picking point
(the one nearest to it along the track) is ``missing`` (fallen, picked by hand, or hidden); it
comes back if it is seen again. Plant: ``round(y_map / plant_spacing)``, the plant whose stem is
nearest when plants stand ``plant_spacing`` apart along the row.

Ripening model (ripeness score 0 green .. 1 red, picking stage at ``ripe_score``): linear in
time from the latest sighting, s(t) = s_last + r (t - t_last). The rate r of a fruit seen at
least twice over at least ``min_fit_span_days`` is the least-squares slope of its own sightings
clamped to [min_rate, max_rate] per day; otherwise r = ``default_rate``. The forecast for a time
before the last sighting is the last score (no back-casting). ``ready_at`` = when s(t) reaches
``ripe_score``.

Plan for a robot and a day: the picking points of the robot's row (its latest mission's site,
unless given) where the expected pickable fruit at the start of work (``work_hour`` local time,
``utc_offset_hours`` from UTC) is at least ``min_expected``, plus points not scanned for
``revisit_days`` (new fruit may have set there), in travel order (increasing track position).
Expected pickable fruit of a point = fruit present there whose forecast is >= ``ripe_score``.

Modules: ``fusion_config`` (parameters, constants, local time), ``ripening`` (a fruit and its
ripening model), ``matching`` (picking points, matching of scans within a row), ``farm_state``
(plans, yields, fruit report); this module turns the database rows into one timeline per row.
"""

# Re-exported: ``farm_server.fusion`` keeps every name it had before the split.
from farm_server.farm_state import FarmState
from farm_server.fusion_config import (DAY, DEFAULT_ROW, OUTCOME_NAMES,  # noqa: F401
                                       OUTCOME_PICKED, FusionConfig, _day_end, day_of,
                                       day_start, sighting_time)
from farm_server.matching import Point, _Grid, _Row, _distance  # noqa: F401
from farm_server.ripening import Fruit  # noqa: F401

__all__ = ['FusionConfig', 'fuse', 'FarmState', 'day_start', 'day_of', 'OUTCOME_PICKED',
           'DEFAULT_ROW']


# ----------------------------------------------------------------------------- fusion

def _map_position(frame_id, x, y, z, track_position, cfg):
    if x is None or y is None or z is None:
        return None
    if frame_id in cfg.map_frames:
        return (x, y, z)
    if frame_id in cfg.cart_frames:
        return (x, y + track_position, z)
    return None


def fuse(missions, observations, picks, cfg, day=None):
    """Fuse every robot's records into a FarmState.

    missions/observations/picks: dicts as returned by FarmDB.fusion_input(). ``day``
    (datetime.date): use only records up to the end of that local day (None = all).
    """
    until = _day_end(day, cfg) if day is not None else None
    mission_row = {}
    mission_list = []
    for m in missions:
        row = m['site'] or DEFAULT_ROW
        mission_row[(m['robot'], m['mission_id'])] = row
        start = m['started'] if m['started'] is not None and \
            m['started'] >= cfg.min_calendar_stamp else m['created']
        if until is None or start < until:
            mission_list.append(dict(robot=m['robot'], mission_id=m['mission_id'], row=row,
                                     start=start))

    rows = {}
    scans = {}          # (row, robot, mission, point, created) -> [time, sightings]
    scan_track = {}     # (robot, mission, point) -> track position (for pick records)
    skipped = 0
    for o in observations:
        t = sighting_time(o['stamp'], o['created'], cfg)
        if until is not None and t >= until:
            continue
        row = mission_row.get((o['robot'], o['mission_id']), DEFAULT_ROW)
        r = rows.get(row)
        if r is None:
            r = rows[row] = _Row(row, cfg)
        point = r.point(o['picking_point'])
        point.positions.append(o['track_position'])
        scan_track[(o['robot'], o['mission_id'], o['picking_point'])] = o['track_position']
        # one scan = one store transaction (database_pkg writes a scan's tomatoes together,
        # with one `created` time); a mission may scan the same point again later
        key = (row, o['robot'], o['mission_id'], o['picking_point'], o['created'])
        entry = scans.get(key)
        if entry is None:
            entry = scans[key] = [t, []]
        entry[0] = min(entry[0], t)
        position = _map_position(o['frame_id'], o['x'], o['y'], o['z'], o['track_position'], cfg)
        if position is None:
            point.unlocalised += 1
            skipped += 1
            continue
        entry[1].append((position, o['ripeness_score'], o['ripeness_stage'], o['robot'],
                         o['mission_id'], o['picking_point'], o['id']))

    # one timeline per row: scans and successful picks, in time order (scans first on ties)
    timeline = []
    for (row, _robot, _mission, pp, _created), (t, sightings) in scans.items():
        rows[row].point(pp).scans.append(t)
        timeline.append((t, 0, row, sightings))
    pick_list = []
    unmatched = 0
    for p in picks:
        t = sighting_time(p['stamp'], p['created'], cfg)
        if until is not None and t >= until:
            continue
        row = mission_row.get((p['robot'], p['mission_id']), DEFAULT_ROW)
        pick_list.append(dict(robot=p['robot'], row=row, outcome=p['outcome'],
                              cycle_time=p['cycle_time'], t=t, mission_id=p['mission_id'],
                              picking_point=p['picking_point']))
        if p['outcome'] != OUTCOME_PICKED:
            continue
        track = scan_track.get((p['robot'], p['mission_id'], p['picking_point']))
        if track is None and row in rows and p['picking_point'] in rows[row].points and \
                rows[row].points[p['picking_point']].positions:
            track = rows[row].points[p['picking_point']].track_position
        position = None
        if track is not None:
            position = _map_position(p['frame_id'], p['x'], p['y'], p['z'], track, cfg)
        elif p['frame_id'] in cfg.map_frames:
            position = (p['x'], p['y'], p['z'])
        if position is None:
            unmatched += 1
            continue
        timeline.append((t, 1, row, (position, p['robot'])))
    timeline.sort(key=lambda e: (e[0], e[1]))
    for t, kind, row, payload in timeline:
        if kind == 0:
            if payload:
                rows[row].scan(t, payload)
        elif row not in rows or not rows[row].pick(t, payload[0], payload[1]):
            unmatched += 1
    for r in rows.values():
        r.finish()
    return FarmState(cfg, until, rows, mission_list, pick_list, unmatched, skipped)
