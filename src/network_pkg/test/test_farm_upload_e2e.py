"""End to end, against the real server process on SQLite and on PostgreSQL: two robots upload
concurrently while one of them keeps recording; the server is SIGKILLed mid-upload and
restarted; one uploader is SIGKILLed mid-upload and restarted. Afterwards the server holds every
row of both robots' local stores exactly once, with the same content."""
import itertools
import os
import threading

import pytest

import farm_harness
from database_pkg.store import Store
from farm_server.db import FarmDB
from network_pkg.outbox import WIRE_COLUMNS

_names = itertools.count()


@pytest.fixture(scope='module')
def postgres():
    if farm_harness.postgres_bindir() is None:
        pytest.skip('PostgreSQL binaries (initdb, pg_ctl) not installed: '
                    'apt-get install postgresql')
    cluster = farm_harness.PostgresCluster().start()
    yield cluster
    cluster.stop()


@pytest.fixture(params=['sqlite', 'postgresql'])
def db_url(request, tmp_path):
    if request.param == 'sqlite':
        return 'sqlite:///' + str(tmp_path / 'farm.db')
    return request.getfixturevalue('postgres').create_database('farm_e2e_%d' % next(_names))


def live_recording(path, stop, done):
    """A mission still running on robot_a while it uploads; also closes an old mission again
    (its revision changes after it was uploaded)."""
    with Store(path, synchronous='NORMAL') as store:
        t = farm_harness.DAY * 30 + 1.7e9
        for k in range(25):
            if stop.wait(0.06):
                break
            store.add_observations('live', k, 0.5 * k, [
                farm_harness.tomato(i, (0.5, 0.04 * i, 0.9), 0.75, t + k) for i in range(6)],
                site='row1')
            store.add_pick_record(farm_harness.pick('live', k, 0, (0.5, 0.0, 0.9), t + k + 1))
            if k == 10:
                store.end_mission('robot1-mission0', 2.0e9, 'closed again with a new summary')
        store.end_mission('live', t + 100, 'live mission done')
    done.set()


def server_total(db):
    return sum(db.counts().values())


def test_two_robots_every_row_exactly_once_across_server_and_uploader_crashes(db_url, tmp_path):
    work = str(tmp_path)
    db = FarmDB(db_url)
    tokens = dict((r, db.add_robot(r)) for r in ('robot_a', 'robot_b'))
    paths = dict((r, os.path.join(work, '%s.db' % r)) for r in tokens)
    for seed, robot in enumerate(sorted(paths), start=1):
        farm_harness.fill_store(paths[robot], seed, missions=3, points=20, fruit=20)
    initial = sum(farm_harness.pending(p) for p in paths.values())

    server = farm_harness.FarmServer(db_url, work).start()
    uploaders = {}
    stop, done = threading.Event(), threading.Event()
    writer = threading.Thread(target=live_recording, args=(paths['robot_a'], stop, done))
    try:
        for robot in sorted(paths):
            uploaders[robot] = farm_harness.start_uploader(
                paths[robot], server.url, tokens[robot], work, robot, batch_size=40,
                min_interval=0.08)
        writer.start()

        # 1. the server dies (SIGKILL) mid-upload, then comes back on the same port
        farm_harness.wait_for(lambda: server_total(db) >= initial // 4, 120,
                              'a quarter of the rows on the server')
        server.kill()
        at_kill = server_total(db)
        assert 0 < at_kill < initial, 'the server must be stopped mid-upload'
        assert all(farm_harness.pending(p) > 0 for p in paths.values())

        def uploader_logs():
            return dict((r, open(os.path.join(work, 'uploader_%s.log' % r)).read()) for r in paths)

        def backing_off():
            # an uploader that has meanwhile marked its last batch has nothing to send: it is
            # idle and never asks the server, so it cannot notice
            return all('unreachable' in text or farm_harness.pending(paths[r]) == 0
                       for r, text in uploader_logs().items())
        try:
            farm_harness.wait_for(backing_off, 90, 'both uploaders to notice the server is down')
        except AssertionError as e:
            raise AssertionError('%s; pending %s; uploader logs: %s' % (
                e, dict((r, farm_harness.pending(p)) for r, p in paths.items()),
                dict((r, text[-800:]) for r, text in uploader_logs().items())))
        server.start()

        # 2. robot_a's uploader dies (SIGKILL) mid-upload and is restarted
        farm_harness.wait_for(lambda: server_total(db) >= at_kill + 200, 120,
                              'upload resumed after the server restart')
        uploaders['robot_a'].kill()
        uploaders['robot_a'].wait(10)
        assert farm_harness.pending(paths['robot_a']) > 0, 'must be killed mid-upload'
        uploaders['robot_a'] = farm_harness.start_uploader(
            paths['robot_a'], server.url, tokens['robot_a'], work, 'robot_a_again',
            batch_size=40, min_interval=0.08)

        assert done.wait(120), 'the live recording did not finish'
        farm_harness.wait_for(lambda: all(farm_harness.pending(p) == 0 for p in paths.values()),
                              240, 'both stores fully uploaded')
    finally:
        stop.set()
        if writer.is_alive():
            writer.join(10)
        for proc in uploaders.values():
            farm_harness.stop_process(proc)
        server.stop()

    # every row exactly once, same content, owned by the robot that sent it
    local_total = 0
    for robot, path in paths.items():
        local = farm_harness.local_rows(path)
        for table, rows in local.items():
            local_total += len(rows)
            stored = db.rows(table, robot=robot)
            assert len(stored) == len(rows), (robot, table)
            by_id = dict((r['id'], r) for r in stored)
            assert set(by_id) == set(rows), (robot, table)
            for row_id, row in rows.items():
                server_row = dict((c, by_id[row_id][c]) for c in WIRE_COLUMNS[table])
                assert server_row == row, (robot, table, row_id)
    assert server_total(db) == local_total
    old = [m for m in db.rows('missions', robot='robot_a') if m['mission_id'] ==
           'robot1-mission0'][0]
    assert old['summary'] == 'closed again with a new summary' and old['revision'] >= 2
    db.dispose()


def test_the_same_batch_posted_concurrently_is_stored_once(db_url, tmp_path):
    """A retry racing its original (e.g. after a client time-out): both succeed, one copy."""
    import requests
    work = str(tmp_path)
    db = FarmDB(db_url)
    token = db.add_robot('robot_r')
    path = os.path.join(work, 'robot_r.db')
    farm_harness.fill_store(path, 5, missions=1, points=4, fruit=20)
    local = farm_harness.local_rows(path)
    body = dict((t, list(rows.values())) for t, rows in local.items())
    size = sum(len(v) for v in body.values())
    server = farm_harness.FarmServer(db_url, work).start()
    answers = []

    def post():
        answers.append(requests.post(server.url + '/api/v1/upload', json=body, timeout=30,
                                     headers={'Authorization': 'Bearer %s' % token}))
    try:
        threads = [threading.Thread(target=post) for _ in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(60)
    finally:
        server.stop()
    assert [a.status_code for a in answers] == [200] * 4, [a.text for a in answers]
    assert sum(sum(a.json()['inserted'].values()) for a in answers) == size
    assert server_total(db) == size
    db.dispose()
