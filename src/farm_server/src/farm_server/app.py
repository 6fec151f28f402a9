"""The farm server's HTTP API (FastAPI). Build it with ``create_app(FarmDB(...), ...)``.

Writes need a robot's bearer token; a missing or unknown token gets 401 before the body is
looked at. Reads of the farm overview, fusion and page are open (bind to loopback or put the
server behind an authenticating proxy on a farm network).
"""

import collections
import datetime
import logging
import threading
import time
from typing import Optional

import sqlalchemy.exc
from fastapi import Depends, FastAPI, HTTPException, Query
from fastapi.exceptions import RequestValidationError
from fastapi.responses import HTMLResponse, JSONResponse
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from farm_server import db as db_mod
from farm_server import fusion, page, schemas

__all__ = ['create_app', 'ServerSettings', 'API_VERSION']

API_VERSION = '1.0.0'
LOG = logging.getLogger('farm_server')


class ServerSettings(object):
    DEFAULTS = dict(max_batch_rows=1000, max_body_bytes=8 * 1024 * 1024, fusion_cache=8)

    def __init__(self, **kwargs):
        unknown = set(kwargs) - set(self.DEFAULTS)
        if unknown:
            raise ValueError('unknown server setting(s): %s' % ', '.join(sorted(unknown)))
        for key, default in self.DEFAULTS.items():
            value = int(kwargs.get(key, default))
            if value < 1:
                raise ValueError('server setting %s must be >= 1' % key)
            setattr(self, key, value)


class _BodyLimit(object):
    """ASGI middleware: 413 for a request body over ``max_bytes`` (declared or streamed)."""

    class _TooLarge(Exception):
        pass

    def __init__(self, app, max_bytes):
        self.app = app
        self.max_bytes = max_bytes

    async def _reject(self, send):
        body = ('{"detail":"request body larger than %d bytes"}' % self.max_bytes).encode()
        await send({'type': 'http.response.start', 'status': 413,
                    'headers': [(b'content-type', b'application/json'),
                                (b'content-length', str(len(body)).encode())]})
        await send({'type': 'http.response.body', 'body': body})

    async def __call__(self, scope, receive, send):
        if scope['type'] != 'http':
            await self.app(scope, receive, send)
            return
        for name, value in scope.get('headers', ()):
            if name == b'content-length':
                try:
                    too_large = int(value) > self.max_bytes
                except ValueError:
                    too_large = False
                if too_large:
                    await self._reject(send)
                    return
        state = {'bytes': 0, 'started': False}

        async def limited_receive():
            message = await receive()
            if message['type'] == 'http.request':
                state['bytes'] += len(message.get('body', b''))
                if state['bytes'] > self.max_bytes:
                    raise self._TooLarge()
            return message

        async def tracking_send(message):
            if message['type'] == 'http.response.start':
                state['started'] = True
            await send(message)

        try:
            await self.app(scope, limited_receive, tracking_send)
        except self._TooLarge:
            if not state['started']:
                await self._reject(send)


class _FusionCache(object):
    """FarmState per (data version, day); recomputed when records arrive."""

    def __init__(self, db, cfg, size):
        self.db = db
        self.cfg = cfg
        self.size = size
        self.lock = threading.Lock()
        self.entries = collections.OrderedDict()

    def state(self, day):
        key = (self.db.data_version(), day)
        with self.lock:
            if key in self.entries:
                self.entries.move_to_end(key)
                return self.entries[key]
        missions, observations, picks = self.db.fusion_input()
        state = fusion.fuse(missions, observations, picks, self.cfg, day=day)
        with self.lock:
            self.entries[key] = state
            while len(self.entries) > self.size:
                self.entries.popitem(last=False)
        return state


def create_app(farm_db, fusion_cfg=None, settings=None):
    fusion_cfg = fusion_cfg or fusion.FusionConfig()
    settings = settings or ServerSettings()
    cache = _FusionCache(farm_db, fusion_cfg, settings.fusion_cache)
    bearer = HTTPBearer(auto_error=False, description='per-robot token (farm_server token add)')

    app = FastAPI(
        title='Harvest farm server', version=API_VERSION,
        description='Collects the harvesting robots\' records (observations, pick records, '
                    'mission events), fuses them over robots and days, and plans each robot\'s '
                    'day. Uploads are atomic and idempotent (upsert by row id).')
    app.add_middleware(_BodyLimit, max_bytes=settings.max_body_bytes)
    app.state.db = farm_db
    app.state.fusion = cache

    def robot(credentials: Optional[HTTPAuthorizationCredentials] = Depends(bearer)):
        token = credentials.credentials if credentials is not None else None
        name = farm_db.robot_for_token(token)
        if name is None:
            raise HTTPException(status_code=401, detail='missing or invalid robot token',
                                headers={'WWW-Authenticate': 'Bearer'})
        return name

    def today():
        return fusion.day_of(time.time(), fusion_cfg)

    @app.exception_handler(RequestValidationError)
    def _invalid(_request, exc):
        # the field at fault and why; not the offending input (it may be huge, or NaN that
        # JSON cannot carry)
        errors = [{'loc': list(e.get('loc', ())), 'msg': e.get('msg', ''),
                   'type': e.get('type', '')} for e in exc.errors()[:20]]
        return JSONResponse(status_code=422, content={'detail': errors})

    @app.exception_handler(sqlalchemy.exc.OperationalError)
    def _db_unavailable(_request, exc):
        LOG.warning('database unavailable: %s', exc)
        return JSONResponse(status_code=503, content={'detail': 'database unavailable'},
                            headers={'Retry-After': '5'})

    @app.post('/api/v1/upload', response_model=schemas.UploadResult, tags=['robots'],
              responses={401: {'description': 'missing or invalid token'},
                         413: {'description': 'batch over the row or byte limit'},
                         422: {'description': 'malformed batch (the field is named)'}})
    def upload(batch: schemas.UploadBatch, name: str = Depends(robot)):
        """Store a batch of the robot's rows: all or none; rows already stored are skipped."""
        size = batch.size()
        if size > settings.max_batch_rows:
            raise HTTPException(status_code=413, detail='batch of %d rows over the limit of %d'
                                % (size, settings.max_batch_rows))
        rows = dict((table, [r.model_dump() for r in getattr(batch, table)])
                    for table in db_mod.RECORD_TABLES)
        result = farm_db.store_batch(name, rows)
        return schemas.UploadResult(robot=name, rows=result['rows'],
                                    inserted=result['inserted'],
                                    duplicates=result['duplicates'])

    @app.get('/api/v1/plan', response_model=schemas.Plan, tags=['robots'],
             responses={404: {'description': 'no plan: the robot has no records yet'}})
    def plan(day: Optional[datetime.date] = Query(None, description='local date, default today'),
             row: Optional[str] = Query(None, description='default: the latest mission\'s site'),
             name: str = Depends(robot)):
        """The calling robot's picking points worth visiting on ``day``, in travel order."""
        day = day or today()
        result = cache.state(day).plan(name, day, row=row)
        if result is None:
            raise HTTPException(status_code=404, detail='no plan for robot %s: no records of '
                                'its row yet' % name)
        return result

    @app.get('/api/v1/fusion', tags=['farm'])
    def fused(row: str = Query(fusion.DEFAULT_ROW), day: Optional[datetime.date] = None,
              picking_point: Optional[int] = None):
        """Every fruit of a row by picking point and plant: history, status and forecast."""
        day = day or today()
        state = cache.state(day)
        t = fusion.day_start(day, fusion_cfg)
        return {'row': row, 'day': day.isoformat(), 'forecast_at': t,
                'model': fusion_cfg.as_dict(),
                'points': state.fruits(row, t, picking_point=picking_point)}

    @app.get('/api/v1/overview', tags=['farm'])
    def overview(day: Optional[datetime.date] = None):
        """Per row the points with expected ripe fruit, each robot's plan and harvest figures."""
        day = day or today()
        state = cache.state(day)
        t = fusion.day_start(day, fusion_cfg)
        tomorrow = day + datetime.timedelta(days=1)
        t1 = fusion.day_start(tomorrow, fusion_cfg)
        robots, rows_yield = state.yields(day)
        known = dict((r['name'], r) for r in farm_db.robots())
        for r in robots:
            info = known.get(r['robot'], {})
            r['last_upload'] = info.get('last_upload')
            r['plan'] = state.plan(r['robot'], day)
        for name, info in known.items():
            if name not in [r['robot'] for r in robots]:
                robots.append(dict(robot=name, attempts=0, picked=0, picked_today=0,
                                   mean_cycle_time=None, success_rate=None, missions=0,
                                   outcomes={}, last_upload=info.get('last_upload'),
                                   plan=None))
        rows = []
        for name in sorted(state.rows):
            points = state.point_table(name, t)
            ripe1 = state.expected_ripe(name, t1)
            for p in points:
                p['expected_ripe_tomorrow'] = ripe1.get(p['picking_point'], 0)
            rows.append({'row': name, 'points': points})
        return {'day': day.isoformat(), 'start_of_work': t, 'rows': rows,
                'robots': sorted(robots, key=lambda r: r['robot']), 'yield_by_row': rows_yield,
                'model': fusion_cfg.as_dict(), 'generated': time.time()}

    @app.get('/api/v1/health', tags=['farm'])
    def health():
        return {'status': 'ok', 'database': farm_db.dialect,
                'schema_version': farm_db.schema_version(), 'api_version': API_VERSION,
                'max_batch_rows': settings.max_batch_rows}

    @app.get('/', response_class=HTMLResponse, include_in_schema=False)
    def index():
        return HTMLResponse(page.PAGE_HTML)

    return app
