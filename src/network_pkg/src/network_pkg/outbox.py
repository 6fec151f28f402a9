"""Offline-first upload of the robot's local store to the farm server (no rospy here).

- ``Outbox``: the queue is the rows of database_pkg's store with ``uploaded = 0`` (schema
  version 3 indexes them). Batches are read in insertion (rowid) order, missions first, then
  events, pick records and observations; after the server's acknowledgement the batch is marked
  uploaded in one transaction. A mission changed after it was read (its ``revision`` moved on)
  stays queued. A crash between send and mark only re-sends the batch: the server upserts by the
  rows' uuid4 ``id``, so nothing is duplicated. The state lives in the database file, so upload
  resumes where it stopped after a restart of the uploader or the robot.
- ``FarmClient``: HTTP(S) with a per-robot bearer token (``requests``, kept-alive session).
- ``Backoff``: exponential back-off with "equal jitter" (a delay drawn in [cap/2, cap], cap
  doubling per failure up to ``maximum``), so robots that lost the server together do not come
  back in lock-step, and none retries faster than cap/2.
- ``Uploader``: one ``step()`` sends at most one batch and says how long to wait before the next.
"""

import json
import random
import sqlite3
import threading
import time

import requests

from database_pkg.store import Store

__all__ = ['Outbox', 'Batch', 'FarmClient', 'UploadError', 'Backoff', 'Uploader',
           'WIRE_COLUMNS', 'TABLE_ORDER']

#: columns sent per table (the store's, less the local ``uploaded`` flag)
WIRE_COLUMNS = {
    'missions': ('id', 'created', 'mission_id', 'started', 'ended', 'site', 'summary',
                 'revision'),
    'observations': ('id', 'created', 'mission_id', 'picking_point', 'track_position',
                     'detection_id', 'x', 'y', 'z', 'frame_id', 'radius', 'ripeness_stage',
                     'ripeness_score', 'pickable', 'pick_order', 'stamp', 'image_id'),
    'pick_records': ('id', 'created', 'mission_id', 'picking_point', 'target_id', 'x', 'y', 'z',
                     'frame_id', 'outcome', 'reason', 'state_names', 'state_durations',
                     'cycle_time', 'stamp'),
    'events': ('id', 'created', 'mission_id', 'stamp', 'kind', 'state', 'detail'),
}
#: order in which a batch is filled (missions first: the server learns a row's site early)
TABLE_ORDER = ('missions', 'events', 'pick_records', 'observations')
MIN_SCHEMA_VERSION = 3


def _wire_row(table, row):
    if table == 'observations':
        row['pickable'] = bool(row['pickable'])
    elif table == 'pick_records':
        row['state_names'] = json.loads(row['state_names'])
        row['state_durations'] = json.loads(row['state_durations'])
    return row


class Batch(object):
    """Rows read from the outbox: ``rows`` {table: [wire dicts]} and what to mark once sent."""

    def __init__(self):
        self.rows = dict((t, []) for t in TABLE_ORDER)

    def __len__(self):
        return sum(len(v) for v in self.rows.values())

    def payload(self, batch_id=None):
        body = dict((t, v) for t, v in self.rows.items() if v)
        if batch_id:
            body['batch_id'] = batch_id
        return body


class Outbox(object):
    """The queue of rows not yet acknowledged by the server, over the robot's store file."""

    def __init__(self, path, busy_timeout=10.0):
        # Open through database_pkg once: creates or migrates the file (schema >= 3 needed).
        with Store(path, synchronous='NORMAL', busy_timeout=busy_timeout) as store:
            if store.schema_version < MIN_SCHEMA_VERSION:
                raise RuntimeError('store %s has schema %d; the outbox needs >= %d'
                                   % (path, store.schema_version, MIN_SCHEMA_VERSION))
        self.path = path
        self._lock = threading.Lock()
        self._conn = sqlite3.connect(path, timeout=float(busy_timeout), isolation_level=None,
                                     check_same_thread=False)
        # Marks are cheap to lose (the batch is only sent again): no fsync per mark.
        self._conn.execute('PRAGMA synchronous=NORMAL')

    def close(self):
        with self._lock:
            self._conn.close()

    def pending_counts(self):
        with self._lock:
            return dict((t, self._conn.execute('SELECT COUNT(*) FROM %s WHERE uploaded = 0'
                                               % t).fetchone()[0]) for t in TABLE_ORDER)

    def next_batch(self, max_rows):
        """Up to ``max_rows`` queued rows, one consistent snapshot of the file."""
        batch = Batch()
        room = int(max_rows)
        with self._lock:
            self._conn.execute('BEGIN')
            try:
                for table in TABLE_ORDER:
                    if room <= 0:
                        break
                    columns = WIRE_COLUMNS[table]
                    cur = self._conn.execute(
                        'SELECT %s FROM %s WHERE uploaded = 0 ORDER BY rowid LIMIT ?'
                        % (', '.join(columns), table), (room,))
                    rows = [_wire_row(table, dict(zip(columns, r))) for r in cur.fetchall()]
                    batch.rows[table] = rows
                    room -= len(rows)
            finally:
                self._conn.execute('COMMIT')
        return batch

    def mark_uploaded(self, batch):
        """Mark a sent batch uploaded, in one transaction. Returns the number of rows marked."""
        marked = 0
        with self._lock:
            cur = self._conn.cursor()
            cur.execute('BEGIN IMMEDIATE')
            try:
                for table in TABLE_ORDER:
                    rows = batch.rows[table]
                    if not rows:
                        continue
                    if table == 'missions':
                        # only the revision that was sent: a newer one stays queued
                        cur.executemany('UPDATE missions SET uploaded = 1 WHERE id = ? '
                                        'AND revision = ?', [(r['id'], r['revision'])
                                                             for r in rows])
                    else:
                        cur.executemany('UPDATE %s SET uploaded = 1 WHERE id = ?' % table,
                                        [(r['id'],) for r in rows])
                    marked += cur.rowcount
                cur.execute('COMMIT')
            except BaseException:
                if self._conn.in_transaction:
                    cur.execute('ROLLBACK')
                raise
        return marked


# ------------------------------------------------------------------------------ HTTP client

class UploadError(Exception):
    """A request failed. ``status``: HTTP status, or None when the server was not reached."""

    def __init__(self, message, status=None):
        Exception.__init__(self, message)
        self.status = status


def _detail(response):
    try:
        detail = response.json().get('detail')
    except ValueError:
        return response.text[:200]
    if isinstance(detail, list):   # FastAPI validation errors: name the fields at fault
        return '; '.join('%s: %s' % ('.'.join(str(p) for p in e.get('loc', ())), e.get('msg'))
                         for e in detail[:3])
    return str(detail)


class FarmClient(object):
    """The farm server API as the robot uses it."""

    def __init__(self, base_url, token, timeout=10.0, verify=True):
        self.base_url = base_url.rstrip('/')
        self.timeout = float(timeout)
        self.verify = verify
        self._session = requests.Session()
        self._session.headers['Authorization'] = 'Bearer %s' % token

    def close(self):
        self._session.close()

    def _request(self, method, path, **kwargs):
        try:
            return self._session.request(method, self.base_url + path, timeout=self.timeout,
                                         verify=self.verify, **kwargs)
        except requests.Timeout as e:
            raise UploadError('no answer from %s within %.1f s (%s)'
                              % (self.base_url, self.timeout, type(e).__name__))
        except requests.RequestException as e:
            raise UploadError('server %s unreachable: %s' % (self.base_url,
                                                            type(e).__name__))

    def upload(self, payload):
        """POST one batch; returns the server's answer (dict) or raises UploadError."""
        response = self._request('POST', '/api/v1/upload', json=payload)
        if response.status_code == 200:
            return response.json()
        raise UploadError('upload refused: HTTP %d %s' % (response.status_code,
                                                          _detail(response)),
                          status=response.status_code)

    def plan(self, day=None, row=None):
        """The robot's plan (dict) for ``day`` (ISO date, default the server's today) or None
        when the server has none for it yet (404)."""
        params = {}
        if day:
            params['day'] = day
        if row:
            params['row'] = row
        response = self._request('GET', '/api/v1/plan', params=params)
        if response.status_code == 200:
            return response.json()
        if response.status_code == 404:
            return None
        raise UploadError('plan request refused: HTTP %d %s' % (response.status_code,
                                                                _detail(response)),
                          status=response.status_code)


# ------------------------------------------------------------------------------ back-off

class Backoff(object):
    """Exponential back-off with equal jitter: delay in [cap/2, cap], cap = initial * 2^(n-1)
    capped at ``maximum`` after the n-th consecutive failure."""

    def __init__(self, initial=1.0, maximum=60.0, factor=2.0, rng=None):
        if not 0.0 < initial <= maximum or factor < 1.0:
            raise ValueError('back-off needs 0 < initial <= maximum and factor >= 1')
        self.initial = float(initial)
        self.maximum = float(maximum)
        self.factor = float(factor)
        self._rng = rng or random.Random()
        self.failures = 0

    def cap(self):
        if self.failures <= 0:
            return 0.0
        exponent = min(self.failures - 1, 64)
        return min(self.maximum, self.initial * self.factor ** exponent)

    def failure(self):
        """Count a failure; returns the delay before the next attempt [s]."""
        self.failures += 1
        cap = self.cap()
        return cap * (0.5 + 0.5 * self._rng.random())

    def success(self):
        self.failures = 0


# ------------------------------------------------------------------------------ uploader

class Uploader(object):
    """Drains the outbox into the server, one batch per ``step()``. Thread-safe status."""

    def __init__(self, outbox, client, batch_size=200, backoff=None, idle_period=2.0,
                 min_interval=0.0, clock=time.time):
        if batch_size < 1:
            raise ValueError('batch_size must be >= 1')
        self.outbox = outbox
        self.client = client
        self.max_batch_size = int(batch_size)
        self.batch_size = int(batch_size)
        self.backoff = backoff or Backoff()
        self.idle_period = float(idle_period)
        self.min_interval = float(min_interval)
        self.clock = clock
        self._lock = threading.Lock()
        self._stats = dict(sent=0, batches=0, duplicates=0, failures=0, last_error='',
                           last_error_status=None, last_error_time=None,
                           last_success_time=None, last_batch_rows=0, next_attempt_in=0.0,
                           consecutive_failures=0, drained=False)

    def status(self):
        with self._lock:
            out = dict(self._stats)
        out['batch_size'] = self.batch_size
        return out

    def _failed(self, text, status):
        delay = self.backoff.failure()
        with self._lock:
            s = self._stats
            s['failures'] += 1
            s['consecutive_failures'] = self.backoff.failures
            s['last_error'] = text
            s['last_error_status'] = status
            s['last_error_time'] = self.clock()
            s['next_attempt_in'] = delay
        return delay

    def step(self):
        """Send at most one batch. Returns the seconds to wait before the next step."""
        try:
            batch = self.outbox.next_batch(self.batch_size)
        except sqlite3.Error as e:
            return self._failed('local store: %s' % e, None)
        if not len(batch):
            with self._lock:
                self._stats['drained'] = True
                self._stats['next_attempt_in'] = self.idle_period
            return self.idle_period
        try:
            result = self.client.upload(batch.payload())
        except UploadError as e:
            if e.status == 413 and self.batch_size > 1:
                # the server's limit is lower than ours: halve and retry at once
                self.batch_size = max(1, self.batch_size // 2)
                with self._lock:
                    self._stats['last_error'] = '%s; batch size now %d' % (e, self.batch_size)
                    self._stats['last_error_status'] = e.status
                    self._stats['last_error_time'] = self.clock()
                return 0.0
            return self._failed(str(e), e.status)
        try:
            self.outbox.mark_uploaded(batch)
        except sqlite3.Error as e:
            # the server has the rows; they will be sent again and skipped as duplicates
            return self._failed('local store (marking a sent batch): %s' % e, None)
        self.backoff.success()
        with self._lock:
            s = self._stats
            s['sent'] += len(batch)
            s['batches'] += 1
            s['duplicates'] += int(result.get('duplicates', 0))
            s['last_success_time'] = self.clock()
            s['last_batch_rows'] = len(batch)
            s['consecutive_failures'] = 0
            s['drained'] = False
            s['next_attempt_in'] = self.min_interval
        return self.min_interval
