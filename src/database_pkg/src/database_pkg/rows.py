"""Rows of the local mission store (no rospy): the dicts written, validated; the dicts read back.

Input is validated completely before the store writes anything: a missing field, a wrong type, a
non-finite number or an out-of-range stage, outcome or phase raises ``ValueError`` naming the
field. The ``*_row`` functions return the column values the store inserts; the ``*_dict``
functions turn a selected row (a dict of columns) into the dict the store returns.
"""

import json
import math
import numbers

from database_pkg.schema import OUTCOMES, PHASES, RIPENESS_STAGES

# ---------------------------------------------------------------- validation helpers

def _field(what, data, key):
    try:
        return data[key]
    except (KeyError, TypeError):
        raise ValueError('%s: missing field %r' % (what, key))


def _text(what, key, value, allow_empty=True):
    if not isinstance(value, str):
        raise ValueError('%s: %s must be a string, got %r' % (what, key, value))
    if not allow_empty and not value:
        raise ValueError('%s: %s must not be empty' % (what, key))
    return value


def _int(what, key, value):
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError('%s: %s must be an integer, got %r' % (what, key, value))
    return int(value)


def _real(what, key, value, minimum=None, maximum=None):
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError('%s: %s must be a number, got %r' % (what, key, value))
    value = float(value)
    if not math.isfinite(value):
        raise ValueError('%s: %s must be finite, got %r' % (what, key, value))
    if minimum is not None and value < minimum:
        raise ValueError('%s: %s must be >= %g, got %g' % (what, key, minimum, value))
    if maximum is not None and value > maximum:
        raise ValueError('%s: %s must be <= %g, got %g' % (what, key, maximum, value))
    return value


def _position(what, value, allow_none):
    if value is None:
        if allow_none:
            return None, None, None
        raise ValueError('%s: position is required' % what)
    try:
        values = list(value)
    except TypeError:
        raise ValueError('%s: position must be a sequence of 3 numbers, got %r' % (what, value))
    if len(values) != 3:
        raise ValueError('%s: position must have 3 components, got %d' % (what, len(values)))
    return tuple(_real(what, 'position.' + axis, v) for axis, v in zip('xyz', values))


def _mission_id(what, data):
    return _text(what, 'mission_id', _field(what, data, 'mission_id'), allow_empty=False)


# ---------------------------------------------------------------- written rows

def observation_row(obs):
    """The observations columns from detection_id to image_id of one scanned tomato."""
    what = 'observation'
    pickable = _field(what, obs, 'pickable')
    if not isinstance(pickable, (bool, int)) or isinstance(pickable, float):
        raise ValueError('%s: pickable must be a bool, got %r' % (what, pickable))
    pickable = bool(pickable)
    # A fruit without a valid 3D point (None) can only be a non-pickable one.
    x, y, z = _position(what, _field(what, obs, 'position'), allow_none=not pickable)
    stage = _int(what, 'ripeness_stage', _field(what, obs, 'ripeness_stage'))
    if stage not in RIPENESS_STAGES:
        raise ValueError('%s: ripeness_stage must be one of %s, got %d'
                         % (what, RIPENESS_STAGES, stage))
    pick_order = _int(what, 'pick_order', _field(what, obs, 'pick_order'))
    if pick_order < -1:
        raise ValueError('%s: pick_order must be >= -1, got %d' % (what, pick_order))
    return (
        _int(what, 'detection_id', _field(what, obs, 'detection_id')),
        x, y, z,
        _text(what, 'frame_id', _field(what, obs, 'frame_id'), allow_empty=x is None),
        _real(what, 'radius', _field(what, obs, 'radius'), minimum=0.0),
        stage,
        _real(what, 'ripeness_score', _field(what, obs, 'ripeness_score')),
        int(pickable),
        pick_order,
        _real(what, 'stamp', _field(what, obs, 'stamp'), minimum=0.0),
        _text(what, 'image_id', _field(what, obs, 'image_id')),
    )


def pick_record_row(record):
    """The pick_records columns from mission_id to stamp of a PickRecord dict."""
    what = 'pick record'
    mission_id = _mission_id(what, record)
    x, y, z = _position(what, _field(what, record, 'position'), allow_none=False)
    outcome = _int(what, 'outcome', _field(what, record, 'outcome'))
    if outcome not in OUTCOMES:
        raise ValueError('%s: outcome must be one of %s, got %d' % (what, OUTCOMES, outcome))
    names = _field(what, record, 'state_names')
    durations = _field(what, record, 'state_durations')
    if isinstance(names, str) or isinstance(durations, str):
        raise ValueError('%s: state_names and state_durations must be lists' % what)
    names = [_text(what, 'state_names[%d]' % i, n) for i, n in enumerate(names)]
    durations = [_real(what, 'state_durations[%d]' % i, d, minimum=0.0)
                 for i, d in enumerate(durations)]
    if len(names) != len(durations):
        raise ValueError('%s: %d state names but %d state durations'
                         % (what, len(names), len(durations)))
    stamp = _real(what, 'stamp', _field(what, record, 'stamp'), minimum=0.0)
    row = (
        mission_id,
        _int(what, 'picking_point', _field(what, record, 'picking_point')),
        _int(what, 'target_id', _field(what, record, 'target_id')),
        x, y, z,
        _text(what, 'frame_id', _field(what, record, 'frame_id'), allow_empty=False),
        outcome,
        _text(what, 'reason', _field(what, record, 'reason')),
        json.dumps(names),
        json.dumps(durations),
        _real(what, 'cycle_time', _field(what, record, 'cycle_time'), minimum=0.0),
        stamp,
    )
    return row


def event_row(event):
    """(mission_id, stamp, kind, state, detail) of a MissionEvent dict."""
    what = 'event'
    mission_id = _mission_id(what, event)
    stamp = _real(what, 'stamp', _field(what, event, 'stamp'), minimum=0.0)
    kind = _text(what, 'kind', _field(what, event, 'kind'), allow_empty=False)
    state = _text(what, 'state', _field(what, event, 'state'))
    detail = _text(what, 'detail', _field(what, event, 'detail'))
    return mission_id, stamp, kind, state, detail


def checkpoint_row(checkpoint):
    """(mission_id, stamp, the checkpoints columns from robot to outcome) of a Checkpoint dict."""
    what = 'checkpoint'
    mission_id = _mission_id(what, checkpoint)
    robot = _text(what, 'robot', _field(what, checkpoint, 'robot'))
    stamp = _real(what, 'stamp', _field(what, checkpoint, 'stamp'), minimum=0.0)
    points = _field(what, checkpoint, 'points')
    if isinstance(points, str):
        raise ValueError('%s: points must be a list' % what)
    points = [_int(what, 'points[%d]' % i, p) for i, p in enumerate(points)]
    point_index = _int(what, 'point_index', _field(what, checkpoint, 'point_index'))
    if point_index < -1 or point_index > len(points):
        raise ValueError('%s: point_index must be in [-1, %d], got %d'
                         % (what, len(points), point_index))
    done = []
    for i, item in enumerate(_field(what, checkpoint, 'targets_done')):
        try:
            target, position = item
        except (TypeError, ValueError):
            raise ValueError('%s: targets_done[%d] must be (target_id, (x, y, z))' % (what, i))
        done.append([_int(what, 'targets_done[%d]' % i, target),
                     list(_position(what, position, allow_none=False))])
    phase = _text(what, 'phase', _field(what, checkpoint, 'phase'))
    if phase not in PHASES:
        raise ValueError('%s: phase must be one of %s, got %r' % (what, PHASES, phase))
    holding = _field(what, checkpoint, 'holding')
    finished = _field(what, checkpoint, 'finished')
    for key, value in (('holding', holding), ('finished', finished)):
        if not isinstance(value, bool):
            raise ValueError('%s: %s must be a bool, got %r' % (what, key, value))
    tx, ty, tz = _position(what, _field(what, checkpoint, 'target_position'), allow_none=True)
    row = (robot, stamp, json.dumps(points), point_index,
           _int(what, 'picking_point', _field(what, checkpoint, 'picking_point')),
           json.dumps(done), _int(what, 'target_id', _field(what, checkpoint, 'target_id')),
           tx, ty, tz, phase, int(holding), int(finished),
           _text(what, 'outcome', _field(what, checkpoint, 'outcome')))
    return mission_id, stamp, row


# ---------------------------------------------------------------- rows read back

def observation_dict(row):
    """An observation row with its position as a tuple (None without a 3D point)."""
    xyz = (row.pop('x'), row.pop('y'), row.pop('z'))
    row['position'] = None if xyz[0] is None else xyz
    row['pickable'] = bool(row['pickable'])
    return row


def pick_record_dict(row):
    """A pick record row with its position as a tuple and its state lists decoded."""
    row['position'] = (row.pop('x'), row.pop('y'), row.pop('z'))
    row['state_names'] = json.loads(row['state_names'])
    row['state_durations'] = json.loads(row['state_durations'])
    return row


def checkpoint_dict(row):
    """A checkpoint row as the dict put_checkpoint takes (plus id, created, updated)."""
    row['points'] = json.loads(row['points'])
    row['targets_done'] = [(d[0], tuple(d[1])) for d in json.loads(row['targets_done'])]
    xyz = (row.pop('target_x'), row.pop('target_y'), row.pop('target_z'))
    row['target_position'] = None if xyz[0] is None else xyz
    row['holding'] = bool(row['holding'])
    row['finished'] = bool(row['finished'])
    return row
