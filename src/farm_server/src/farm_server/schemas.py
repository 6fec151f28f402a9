"""Wire format of the farm server API (pydantic v2 models, strict: no silent coercion).

An upload batch carries rows of the robot's local store (database_pkg.store) keyed by their
stable uuid4 ``id`` (32 lowercase hex digits). Every number must be finite; unknown fields are
refused. A malformed row makes the whole batch fail with 422 naming the field, e.g.
``["body", "observations", 3, "radius"]``.
"""

from typing import List, Optional

from pydantic import BaseModel, ConfigDict, Field, model_validator

from farm_server.fusion_config import OUTCOME_NAMES

__all__ = ['Mission', 'Observation', 'PickRecord', 'Event', 'UploadBatch', 'UploadResult',
           'PlanPoint', 'Plan']

ID_PATTERN = r'^[0-9a-f]{32}$'
_STRICT = ConfigDict(extra='forbid', strict=True, allow_inf_nan=False)

def _id():
    return Field(pattern=ID_PATTERN, description='stable unique row id (uuid4 hex)')


def _text(max_length, min_length=0):
    return Field(min_length=min_length, max_length=max_length)


class Mission(BaseModel):
    model_config = _STRICT
    id: str = _id()
    created: float = Field(ge=0, description='wall-clock time of insertion on the robot (Unix s)')
    mission_id: str = _text(200, 1)
    started: Optional[float] = Field(default=None, ge=0)
    ended: Optional[float] = Field(default=None, ge=0)
    site: str = _text(200)
    summary: str = _text(10000)
    revision: int = Field(ge=0, description='bumped by the robot whenever the mission changes')


class Observation(BaseModel):
    model_config = _STRICT
    id: str = _id()
    created: float = Field(ge=0)
    mission_id: str = _text(200, 1)
    picking_point: int = Field(ge=0)
    track_position: float
    detection_id: int
    x: Optional[float] = None
    y: Optional[float] = None
    z: Optional[float] = None
    frame_id: str = _text(100)
    radius: float = Field(ge=0)
    ripeness_stage: int = Field(ge=0, le=3)
    ripeness_score: float
    pickable: bool
    pick_order: int = Field(ge=-1)
    stamp: float = Field(ge=0)
    image_id: str = _text(200)

    @model_validator(mode='after')
    def _point_all_or_none(self):
        given = [v is not None for v in (self.x, self.y, self.z)]
        if any(given) and not all(given):
            raise ValueError('x, y and z must all be numbers or all be null')
        return self


class PickRecord(BaseModel):
    model_config = _STRICT
    id: str = _id()
    created: float = Field(ge=0)
    mission_id: str = _text(200, 1)
    picking_point: int = Field(ge=0)
    target_id: int
    x: float
    y: float
    z: float
    frame_id: str = _text(100, 1)
    outcome: int = Field(ge=min(OUTCOME_NAMES), le=max(OUTCOME_NAMES),
                         description='PickRecord.OUTCOME_*: ' + ', '.join(
                             '%d %s' % item for item in sorted(OUTCOME_NAMES.items())))
    reason: str = _text(2000)
    state_names: List[str] = Field(max_length=100)
    state_durations: List[float] = Field(max_length=100)
    cycle_time: float = Field(ge=0)
    stamp: float = Field(ge=0)

    @model_validator(mode='after')
    def _same_lengths(self):
        if len(self.state_names) != len(self.state_durations):
            raise ValueError('state_names and state_durations must have the same length')
        if any(d < 0 for d in self.state_durations):
            raise ValueError('state_durations must be >= 0')
        return self


class Event(BaseModel):
    model_config = _STRICT
    id: str = _id()
    created: float = Field(ge=0)
    mission_id: str = _text(200, 1)
    stamp: float = Field(ge=0)
    kind: str = _text(64, 1)
    state: str = _text(64)
    detail: str = _text(10000)


class UploadBatch(BaseModel):
    """Rows of one robot, all stored or none. The robot is the token's, never a field."""
    model_config = ConfigDict(extra='forbid', strict=True)
    batch_id: Optional[str] = Field(default=None, max_length=64,
                                    description='client label for logs; not used for dedup')
    missions: List[Mission] = Field(default_factory=list)
    observations: List[Observation] = Field(default_factory=list)
    pick_records: List[PickRecord] = Field(default_factory=list)
    events: List[Event] = Field(default_factory=list)

    def size(self):
        return (len(self.missions) + len(self.observations) + len(self.pick_records)
                + len(self.events))


class UploadResult(BaseModel):
    robot: str
    rows: int = Field(description='rows in the batch')
    inserted: dict = Field(description='new rows per table')
    duplicates: int = Field(description='rows already stored (a replayed or retried batch)')


class PlanPoint(BaseModel):
    picking_point: int
    track_position: float
    expected_ripe: int
    fruit_present: int
    last_scan: Optional[float] = None
    scans: int
    unlocalised: int
    reasons: List[str]


class Plan(BaseModel):
    robot: str
    row: str
    day: str
    start_of_work: float
    picking_points: List[int] = Field(description='picking point indices in visit order')
    points: List[PlanPoint]
    expected_ripe: int
