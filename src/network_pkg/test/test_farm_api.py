"""The farm server's HTTP API against the real server process (SQLite): tokens, validation,
limits, idempotency, mission revisions, plans; the uploader halving its batch on 413."""
import copy
import datetime
import json
import os
import uuid

import pytest
import requests

import farm_harness
from farm_server.db import FarmDB
from network_pkg.outbox import Outbox

MAX_ROWS = 50
MAX_BYTES = 64 * 1024
T0 = 1.75e9


@pytest.fixture(scope='module')
def farm(tmp_path_factory):
    work = str(tmp_path_factory.mktemp('farm_api'))
    url = 'sqlite:///' + os.path.join(work, 'farm.db')
    config = ('server: {max_batch_rows: %d, max_body_bytes: %d}\n'
              'fusion: {revisit_days: 0}\n'
              'robots: {robot_a: token-a, robot_b: token-b, robot_c: token-c}\n'
              % (MAX_ROWS, MAX_BYTES))
    server = farm_harness.FarmServer(url, work, config_text=config).start()
    db = FarmDB(url)
    yield server, db, work
    server.stop()
    db.dispose()


def auth(token):
    return {'Authorization': 'Bearer %s' % token}


def new_id():
    return uuid.uuid4().hex


def observation(mission_id='m1', point=0, score=0.8, t=T0, y=0.0, **kw):
    row = dict(id=new_id(), created=t + 1, mission_id=mission_id, picking_point=point,
               track_position=0.5 * point, detection_id=0, x=0.5, y=y, z=0.9,
               frame_id='base_link', radius=0.035, ripeness_stage=3 if score >= 0.7 else 0,
               ripeness_score=score, pickable=score >= 0.7, pick_order=0, stamp=t,
               image_id='img')
    row.update(kw)
    return row


def mission(mission_id='m1', revision=1, site='row1', **kw):
    row = dict(id=new_id(), created=T0, mission_id=mission_id, started=T0, ended=None,
               site=site, summary='', revision=revision)
    row.update(kw)
    return row


def post(server, body, token='token-a', raw=None):
    headers = auth(token) if token else {}
    if raw is not None:
        headers['Content-Type'] = 'application/json'
        return requests.post(server.url + '/api/v1/upload', data=raw, headers=headers,
                             timeout=10)
    return requests.post(server.url + '/api/v1/upload', json=body, headers=headers, timeout=10)


def test_openapi_description(farm):
    server, _db, _w = farm
    spec = requests.get(server.url + '/openapi.json', timeout=5).json()
    assert spec['info']['title'] == 'Harvest farm server'
    assert {'/api/v1/upload', '/api/v1/plan', '/api/v1/overview', '/api/v1/fusion'} <= \
        set(spec['paths'])
    assert 'HTTPBearer' in json.dumps(spec['components']['securitySchemes'])
    assert 'Observation' in spec['components']['schemas']


@pytest.mark.parametrize('token', [None, 'wrong-token', ''], ids=['none', 'invalid', 'empty'])
def test_missing_or_invalid_token_is_401_and_touches_nothing(farm, token):
    server, db, _w = farm
    before = (db.counts(), db.robots())
    body = {'observations': [observation()], 'missions': [mission()]}
    r = post(server, body, token=token)
    assert r.status_code == 401 and r.headers.get('www-authenticate') == 'Bearer'
    # a malformed body without a token is still a 401, not a 422
    assert post(server, {'observations': [{'id': 'bad'}]}, token=token).status_code == 401
    r = requests.get(server.url + '/api/v1/plan', headers=auth(token) if token else {},
                     timeout=5)
    assert r.status_code == 401
    assert (db.counts(), db.robots()) == before


@pytest.mark.parametrize('table, bad, field', [
    ('observations', {'radius': 'big'}, 'radius'),
    ('observations', {'ripeness_stage': 7}, 'ripeness_stage'),
    ('observations', {'id': 'not-a-uuid'}, 'id'),
    ('observations', {'pickable': 'yes'}, 'pickable'),
    ('observations', {'picking_point': 2.5}, 'picking_point'),
    ('observations', {'colour': 'red'}, 'colour'),
    ('observations', {'y': None}, None),
    ('missions', {'revision': -1}, 'revision'),
], ids=['wrong type', 'out of range', 'bad id', 'bool as text', 'float as int', 'extra field',
        'half a point', 'negative revision'])
def test_malformed_row_is_422_naming_the_field_and_stores_nothing(farm, table, bad, field):
    server, db, _w = farm
    before = db.counts()
    good = [observation(point=i) for i in range(5)]
    rows = {'missions': [mission()], 'observations': good}
    broken = copy.deepcopy(rows[table][-1])
    broken.update(bad)
    if field == 'colour':
        broken['colour'] = 'red'
    rows[table][-1] = broken
    r = post(server, rows)
    assert r.status_code == 422
    detail = r.json()['detail']
    index = len(rows[table]) - 1
    if field is not None:
        assert any(e['loc'][:3] == ['body', table, index] and e['loc'][-1] == field
                   for e in detail), detail
    else:
        assert any(e['loc'][:3] == ['body', table, index] and 'x, y and z' in e['msg']
                   for e in detail), detail
    assert db.counts() == before


def test_non_finite_number_and_missing_field_are_422(farm):
    server, db, _w = farm
    before = db.counts()
    row = observation()
    text = json.dumps({'observations': [row]}).replace('"ripeness_score": 0.8',
                                                        '"ripeness_score": NaN')
    r = post(server, None, raw=text)
    assert r.status_code == 422
    assert r.json()['detail'][0]['loc'] == ['body', 'observations', 0, 'ripeness_score']
    del row['stamp']
    r = post(server, {'observations': [row]})
    assert r.status_code == 422 and r.json()['detail'][0]['loc'][-1] == 'stamp'
    assert post(server, None, raw='{"observations": [').status_code == 422
    assert db.counts() == before


def test_oversized_batches_are_413_and_store_nothing(farm):
    server, db, _w = farm
    before = db.counts()
    r = post(server, {'observations': [observation(point=i % 20) for i in range(MAX_ROWS + 1)]})
    assert r.status_code == 413 and 'limit of %d' % MAX_ROWS in r.json()['detail']
    huge = observation(image_id='x' * 150)
    body = {'events': [dict(id=new_id(), created=T0, mission_id='m', stamp=T0, kind='state',
                            state='', detail='y' * 9000) for _ in range(10)]}
    r = post(server, body)
    assert r.status_code == 413 and 'bytes' in r.json()['detail']
    assert post(server, {'observations': [huge]}).status_code == 200   # within limits: fine
    after = db.counts()
    assert after['events'] == before['events']
    assert after['observations'] == before['observations'] + 1


def test_replayed_batch_is_idempotent(farm):
    server, db, _w = farm
    rows = {'missions': [mission('replay')],
            'observations': [observation('replay', point=i) for i in range(10)],
            'events': [dict(id=new_id(), created=T0, mission_id='replay', stamp=T0,
                            kind='state', state='DO_START', detail='go')]}
    first = post(server, rows)
    assert first.status_code == 200
    assert first.json()['inserted'] == {'missions': 1, 'observations': 10, 'pick_records': 0,
                                        'events': 1}
    counts = db.counts()
    stored = db.rows('observations', robot='robot_a')
    for _ in range(2):
        again = post(server, rows)
        assert again.status_code == 200
        assert again.json()['duplicates'] == 12 and sum(again.json()['inserted'].values()) == 0
    assert db.counts() == counts
    assert db.rows('observations', robot='robot_a') == stored
    # half old, half new rows: only the new ones are added
    mixed = {'observations': rows['observations'][:5] + [observation('replay', point=20)]}
    result = post(server, mixed).json()
    assert (result['inserted']['observations'], result['duplicates']) == (1, 5)


def test_mission_keeps_the_highest_revision_and_its_robot(farm):
    server, db, _w = farm
    m = mission('revisions', revision=2, summary='rev 2')
    assert post(server, {'missions': [m]}).status_code == 200
    stale = dict(m, revision=1, summary='rev 1 arriving late')
    assert post(server, {'missions': [stale]}).status_code == 200
    newer = dict(m, revision=3, ended=T0 + 100, summary='rev 3')
    assert post(server, {'missions': [newer]}).status_code == 200
    hijack = dict(m, revision=9, summary='robot b overwriting robot a')
    assert post(server, {'missions': [hijack]}, token='token-b').status_code == 200
    row = [r for r in db.rows('missions') if r['id'] == m['id']][0]
    assert (row['robot'], row['revision'], row['summary'], row['ended']) == \
        ('robot_a', 3, 'rev 3', T0 + 100)


def test_plan_endpoint_follows_the_observations(farm):
    server, _db, _w = farm
    day = datetime.date(2025, 6, 14)
    t = datetime.datetime(2025, 6, 13, 9, tzinfo=datetime.timezone.utc).timestamp()
    r = requests.get(server.url + '/api/v1/plan', headers=auth('token-c'), timeout=5)
    assert r.status_code == 404                   # no records of robot_c yet
    first = {'missions': [mission('c-day1', site='row9', started=t)],
             'observations': [observation('c-day1', point=0, score=0.2, t=t),
                              observation('c-day1', point=1, score=0.8, t=t),
                              observation('c-day1', point=2, score=0.75, t=t)]}
    assert post(server, first, token='token-c').status_code == 200
    plan = requests.get(server.url + '/api/v1/plan', params={'day': day.isoformat()},
                        headers=auth('token-c'), timeout=5).json()
    assert (plan['row'], plan['picking_points']) == ('row9', [1, 2])
    # the afternoon scan: point 2's fruit was picked, point 0's fruit is red now
    t2 = t + 6 * 3600
    second = {'observations': [observation('c-day1', point=0, score=0.72, t=t2),
                               observation('c-day1', point=1, score=0.85, t=t2)],
              'pick_records': [dict(id=new_id(), created=t2 + 60, mission_id='c-day1',
                                    picking_point=2, target_id=0, x=0.5, y=0.0, z=0.9,
                                    frame_id='base_link', outcome=0, reason='',
                                    state_names=['DO_CUT'], state_durations=[2.0],
                                    cycle_time=25.0, stamp=t2 + 60)]}
    assert post(server, second, token='token-c').status_code == 200
    plan = requests.get(server.url + '/api/v1/plan', params={'day': day.isoformat()},
                        headers=auth('token-c'), timeout=5).json()
    assert plan['picking_points'] == [0, 1]
    overview = requests.get(server.url + '/api/v1/overview', params={'day': '2025-06-13'},
                            timeout=5).json()
    robot_c = [r for r in overview['robots'] if r['robot'] == 'robot_c'][0]
    assert (robot_c['picked'], robot_c['picked_today'], robot_c['mean_cycle_time']) == \
        (1, 1, 25.0)
    fused = requests.get(server.url + '/api/v1/fusion', params={'row': 'row9', 'day':
                                                                '2025-06-14'},
                         timeout=5).json()
    statuses = sorted(f['status'] for p in fused['points'] for pl in p['plants']
                      for f in pl['fruits'])
    assert statuses == ['harvested', 'present', 'present']


def test_uploader_halves_its_batch_to_the_server_limit(farm, tmp_path):
    server, db, work = farm
    path = str(tmp_path / 'robot_b.db')
    total = farm_harness.fill_store(path, robot_seed=7, missions=1, points=6, fruit=10)
    proc = farm_harness.start_uploader(path, server.url, 'token-b', work, 'halving',
                                       batch_size=4 * MAX_ROWS, until_empty=True)
    assert proc.wait(60) == 0
    assert farm_harness.pending(path) == 0
    local = farm_harness.local_rows(path)
    assert sum(len(v) for v in local.values()) == total + 1      # + the mission row
    for table, rows in local.items():
        server_ids = set(r['id'] for r in db.rows(table, robot='robot_b'))
        assert set(rows) <= server_ids
    assert os.path.getsize(os.path.join(work, 'uploader_halving.log')) > 0
    Outbox(path).close()


def test_new_tokens_never_look_like_a_command_line_option():
    # a token starting with '-' broke `outbox_cli --token TOKEN` (argparse took it for an
    # option); one token in 64 of secrets.token_urlsafe starts so
    from farm_server.db import new_token
    tokens = [new_token() for _ in range(2000)]
    assert not [t for t in tokens if t.startswith('-')]
    assert len(set(tokens)) == len(tokens) and all(len(t) >= 43 for t in tokens)
