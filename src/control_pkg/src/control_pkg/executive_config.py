"""The task planner's configuration: the defaults of config/executive.yaml (the only place they
are written), merged one level deep with the node's `~` parameters of the same names, and checked.

Re-exported by control_pkg.executive_node.
"""
import math
import os

import yaml

from control_pkg import mission as mission_lib


def defaults_path():
    """config/executive.yaml of the control_pkg package: the executive's defaults live only there."""
    here = os.path.dirname(os.path.abspath(__file__))
    source = os.path.join(here, '..', '..', 'config', 'executive.yaml')     # devel space / source
    if os.path.exists(source):
        return os.path.normpath(source)
    import rospkg                                                          # install space
    return os.path.join(rospkg.RosPack().get_path('control_pkg'), 'config', 'executive.yaml')


def load_defaults(path=None):
    """The executive's defaults (a dict) from config/executive.yaml, or from `path`."""
    path = path or defaults_path()
    with open(path) as f:
        data = yaml.safe_load(f)
    if not isinstance(data, dict):
        raise ValueError('%s: the executive defaults must be a mapping' % path)
    return data


def merged_config(overrides, defaults=None):
    """The defaults (config/executive.yaml unless given) updated one level deep with
    `overrides` (a dict from the parameter server)."""
    defaults = load_defaults() if defaults is None else defaults
    cfg = {}
    for key, value in defaults.items():
        if isinstance(value, dict):
            merged = dict(value)
            merged.update((overrides or {}).get(key, {}) or {})
            cfg[key] = merged
        else:
            cfg[key] = (overrides or {}).get(key, value)
    for key in ('home', ):
        for arm in ('left', 'right'):
            joints = cfg[key][arm]
            if len(joints) != 3 or any(math.isnan(float(j)) for j in joints):
                raise ValueError('%s/%s must be 3 finite joint values [lift, boom, forearm], got %r'
                                 % (key, arm, joints))
    pulls = cfg['right_pulls']
    if not isinstance(pulls, (list, tuple)) or not all(
            isinstance(p, (list, tuple)) and len(p) == 3 and
            all(isinstance(v, (int, float)) and math.isfinite(float(v)) for v in p) for p in pulls):
        raise ValueError('right_pulls must be a list of [dx, dy, dz] (finite, m), got %r' % (pulls,))
    watched = cfg['watched_nodes']
    if not isinstance(watched, (list, tuple)) or not all(isinstance(n, str) and n for n in watched):
        raise ValueError('watched_nodes must be a list of node names, got %r' % (watched,))
    for key in ('pull_clearance', 'cut_clearance', 'resume_skip_tolerance', 'checkpoint_wait',
                'node_watch_period', 'standby_standoff', 'cart_wait'):
        if not isinstance(cfg[key], (int, float)) or not math.isfinite(float(cfg[key])) or cfg[key] < 0:
            raise ValueError('%s must be a finite number >= 0, got %r' % (key, cfg[key]))
    if cfg['schedule'] not in mission_lib.SCHEDULES:
        raise ValueError('schedule must be one of %s, got %r' % (', '.join(mission_lib.SCHEDULES),
                                                                 cfg['schedule']))
    if not isinstance(cfg['left_standby'], bool):
        raise ValueError('left_standby must be true or false, got %r' % (cfg['left_standby'],))
    margin = cfg['overlap_margin']
    if not isinstance(margin, (int, float)) or not math.isfinite(float(margin)) or margin < 0:
        raise ValueError('overlap_margin must be a finite number >= 0 (m), got %r' % (margin,))
    tol = cfg['relocate_tolerance']
    if not isinstance(tol, (int, float)) or not math.isfinite(float(tol)) or float(tol) < 0.0:
        raise ValueError('relocate_tolerance must be a finite number >= 0 (m), got %r' % (tol,))
    rtol = cfg['relocate_radius_tolerance']
    if not isinstance(rtol, (int, float)) or not 0.0 <= float(rtol) < 1.0:
        raise ValueError('relocate_radius_tolerance must be a number in [0, 1), got %r' % (rtol,))
    if not isinstance(cfg['relocate_depth_when_smaller'], bool):
        raise ValueError('relocate_depth_when_smaller must be true or false, got %r' % (
            cfg['relocate_depth_when_smaller'],))
    return cfg
