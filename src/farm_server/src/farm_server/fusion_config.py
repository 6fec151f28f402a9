"""Fusion parameters, record constants and the farm's local time (work start, local day).

``FusionConfig`` holds the parameters of matching, the ripening model and planning; the time
helpers turn a local day into the Unix time at which work starts and pick a sighting's time
(see the ``fusion`` module docstring). Pure Python.
"""

import datetime
import math

# The pick outcome codes of harvest_msgs/PickRecord.OUTCOME_*, copied (the farm server runs off the
# robot, without ROS); the one copy in farm_server: schemas.py takes the API's bounds from it, and
# test_record_schema checks it against the message's constants.
OUTCOME_NAMES = {0: 'picked', 1: 'unreachable', 2: 'lost', 3: 'failed', 4: 'dropped'}
OUTCOME_PICKED = 0
DEFAULT_ROW = 'default'
DAY = 86400.0


class FusionConfig(object):
    """Parameters of matching, the ripening model and planning (see the module docstring)."""

    DEFAULTS = dict(
        match_tolerance=0.05,       # m, same fruit if closer than this in the map frame
        plant_spacing=0.35,         # m, plants along the row
        ripe_score=0.7,             # ripeness score of the picking stage
        default_rate=0.07,          # score per day when a fruit's own rate is unknown
        min_rate=0.01,              # score per day, clamp of a fitted rate
        max_rate=0.30,
        min_fit_span_days=0.5,      # sightings must span this long to fit a fruit's own rate
        min_expected=1.0,           # plan a point with at least this many pickable fruit
        revisit_days=7.0,           # plan a point not scanned for this long (0 = never)
        work_hour=6.0,              # local hour at which the day's work starts
        utc_offset_hours=0.0,       # local time - UTC
        min_calendar_stamp=1.0e9,   # s; smaller ROS stamps are simulated time
        cart_frames=('base_link',),
        map_frames=('map',),
    )

    def __init__(self, **kwargs):
        unknown = set(kwargs) - set(self.DEFAULTS)
        if unknown:
            raise ValueError('unknown fusion parameter(s): %s (known: %s)'
                             % (', '.join(sorted(unknown)), ', '.join(sorted(self.DEFAULTS))))
        for key, default in self.DEFAULTS.items():
            value = kwargs.get(key, default)
            if key.endswith('_frames'):
                value = tuple(str(v) for v in value)
            else:
                value = float(value)
                if not math.isfinite(value):
                    raise ValueError('fusion parameter %s must be finite' % key)
            setattr(self, key, value)
        for key in ('match_tolerance', 'plant_spacing', 'default_rate', 'max_rate'):
            if getattr(self, key) <= 0.0:
                raise ValueError('fusion parameter %s must be > 0' % key)
        if not 0.0 <= self.min_rate <= self.max_rate:
            raise ValueError('fusion parameters need 0 <= min_rate <= max_rate')
        if not 0.0 <= self.work_hour < 24.0:
            raise ValueError('work_hour must be in [0, 24)')

    def as_dict(self):
        return dict((k, list(getattr(self, k)) if k.endswith('_frames') else getattr(self, k))
                    for k in self.DEFAULTS)

    def key(self):
        return tuple(sorted((k, str(v)) for k, v in self.as_dict().items()))


# ----------------------------------------------------------------------------- time

def day_start(day, cfg):
    """Unix time at which work starts on ``day`` (a datetime.date) in the farm's local time."""
    midnight = datetime.datetime(day.year, day.month, day.day, tzinfo=datetime.timezone.utc)
    return midnight.timestamp() + (cfg.work_hour - cfg.utc_offset_hours) * 3600.0


def day_of(t, cfg):
    """The farm's local date of Unix time ``t``."""
    local = datetime.datetime.fromtimestamp(t + cfg.utc_offset_hours * 3600.0,
                                            tz=datetime.timezone.utc)
    return local.date()


def _day_end(day, cfg):
    midnight = datetime.datetime(day.year, day.month, day.day, tzinfo=datetime.timezone.utc)
    return midnight.timestamp() + DAY - cfg.utc_offset_hours * 3600.0


def sighting_time(stamp, created, cfg):
    return stamp if stamp >= cfg.min_calendar_stamp else created

