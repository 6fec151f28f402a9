"""Test helpers of network_pkg: a real farm server process, a private PostgreSQL cluster,
robot stores filled through database_pkg.store, uploader processes. No ROS.

Also a command line for the docs screenshot:
    python src/network_pkg/test/farm_harness.py screenshot docs/farm_server.png
"""
import datetime
import os
import pwd
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
PKG_SRC = os.path.normpath(os.path.join(HERE, '..', 'src'))
if PKG_SRC not in sys.path:
    sys.path.insert(0, PKG_SRC)

from database_pkg.store import Store  # noqa: E402
# shared with harvest_bringup's mission_plan rostest (harvest_test_utils, a test_depend)
from harvest_test_utils.farm import FarmServer, subprocess_env  # noqa: E402,F401
from harvest_test_utils.net import free_port, wait_for  # noqa: E402,F401

DAY = 86400.0
CHROMIUM_FLAGS = ['--headless', '--no-sandbox', '--disable-gpu', '--disable-quic',
                  '--disable-background-networking', '--disable-component-update',
                  '--disable-sync', '--no-first-run', '--hide-scrollbars']


# ------------------------------------------------------------------------- PostgreSQL

def postgres_bindir():
    """Directory of initdb/pg_ctl, or None when PostgreSQL is not installed."""
    found = shutil.which('pg_ctl')
    if found and shutil.which('initdb'):
        return os.path.dirname(os.path.realpath(found))
    base = '/usr/lib/postgresql'
    if os.path.isdir(base):
        for version in sorted(os.listdir(base), key=lambda v: [int(x) for x in v.split('.')
                                                               if x.isdigit()], reverse=True):
            bindir = os.path.join(base, version, 'bin')
            if os.path.exists(os.path.join(bindir, 'pg_ctl')):
                return bindir
    return None


class PostgresCluster(object):
    """A throw-away PostgreSQL cluster in a temp dir, on a loopback port, trust auth.

    initdb refuses to run as root: then the cluster is owned by the ``postgres`` user (Debian's
    package creates it) or ``nobody``.
    """

    def __init__(self):
        self.bindir = postgres_bindir()
        if self.bindir is None:
            raise RuntimeError('PostgreSQL binaries (initdb, pg_ctl) not found')
        self.dir = tempfile.mkdtemp(prefix='net_pg_')
        self.data = os.path.join(self.dir, 'data')
        self.port = free_port()
        self.user = None
        if os.geteuid() == 0:
            for name in ('postgres', 'nobody'):
                try:
                    self.user = pwd.getpwnam(name)
                    break
                except KeyError:
                    continue
            if self.user is None:
                raise RuntimeError('running as root and no postgres/nobody user for initdb')
            os.chown(self.dir, self.user.pw_uid, self.user.pw_gid)

    def _run(self, args, timeout=60):
        preexec = None
        env = dict(os.environ, LC_ALL='C', LANG='C')
        if self.user is not None:
            uid, gid = self.user.pw_uid, self.user.pw_gid

            def preexec():
                os.setgid(gid)
                os.setuid(uid)
            env['HOME'] = self.dir
        result = subprocess.run(args, preexec_fn=preexec, env=env, cwd=self.dir,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                timeout=timeout)
        if result.returncode != 0:
            raise RuntimeError('%s failed (%d): %s' % (' '.join(args), result.returncode,
                                                       result.stdout.decode()[-2000:]))
        return result.stdout.decode()

    def start(self):
        self._run([os.path.join(self.bindir, 'initdb'), '-D', self.data, '-U', 'farm',
                   '-A', 'trust', '-E', 'UTF8', '--no-sync'])
        options = ('-c listen_addresses=127.0.0.1 -c unix_socket_directories=%s -c fsync=off '
                   '-c max_connections=50 -p %d' % (self.dir, self.port))
        self._run([os.path.join(self.bindir, 'pg_ctl'), '-D', self.data, '-w', '-t', '60',
                   '-l', os.path.join(self.dir, 'log'), '-o', options, 'start'])
        return self

    def create_database(self, name):
        import psycopg2
        conn = psycopg2.connect(host='127.0.0.1', port=self.port, user='farm', dbname='postgres')
        conn.autocommit = True
        conn.cursor().execute('CREATE DATABASE "%s"' % name)
        conn.close()
        return 'postgresql://farm@127.0.0.1:%d/%s' % (self.port, name)

    def stop(self):
        try:
            self._run([os.path.join(self.bindir, 'pg_ctl'), '-D', self.data, '-m', 'immediate',
                       '-w', 'stop'])
        except (RuntimeError, subprocess.TimeoutExpired):
            pass
        shutil.rmtree(self.dir, ignore_errors=True)


# ------------------------------------------------------------------------- robot data

def tomato(i, position, score, stamp, frame_id='base_link'):
    stage = 3 if score >= 0.7 else 2 if score >= 0.5 else 1 if score >= 0.25 else 0
    return dict(detection_id=i, position=position, frame_id=frame_id, radius=0.035,
                ripeness_stage=stage, ripeness_score=score, pickable=score >= 0.7,
                pick_order=i if score >= 0.7 else -1, stamp=stamp, image_id='img-%d' % i)


def pick(mission_id, point, target, position, stamp, outcome=0, cycle_time=30.0):
    return dict(mission_id=mission_id, picking_point=point, target_id=target,
                position=position, frame_id='base_link', outcome=outcome,
                reason='' if outcome == 0 else 'unreachable',
                state_names=['DO_KINEMATICS', 'DO_MOVE_ROBOT', 'DO_CUT'],
                state_durations=[1.0, cycle_time - 3.0, 2.0], cycle_time=cycle_time,
                stamp=stamp)


def fill_store(path, robot_seed, missions=2, points=12, fruit=8, site='row1', t0=1.7e9,
               synchronous='NORMAL'):
    """A robot's store with ``missions`` missions of scans, picks and events. Returns rows."""
    rng = random.Random(robot_seed)
    total = 0
    with Store(path, synchronous=synchronous) as store:
        for m in range(missions):
            mission_id = 'robot%d-mission%d' % (robot_seed, m)
            t = t0 + m * DAY + robot_seed * 3600.0
            store.add_event(dict(mission_id=mission_id, stamp=t, kind='state', state='DO_START',
                                 detail='start'), site=site)
            total += 1
            for k in range(points):
                obs = [tomato(i, (0.5 + rng.uniform(-0.1, 0.1), rng.uniform(-0.2, 0.2),
                                  0.8 + rng.uniform(0, 0.3)), round(rng.random(), 3),
                              t + k * 60.0) for i in range(fruit)]
                store.add_observations(mission_id, k, 0.5 * k, obs, site=site)
                total += len(obs)
                for j, o in enumerate(obs[:2]):
                    store.add_pick_record(pick(mission_id, k, j, o['position'],
                                               t + k * 60.0 + 10 + j,
                                               outcome=rng.choice([0, 0, 0, 1])), site=site)
                    total += 1
                store.add_event(dict(mission_id=mission_id, stamp=t + k * 60.0, kind='state',
                                     state='DO_MOVE_BASE', detail='point %d' % k), site=site)
                total += 1
            store.add_event(dict(mission_id=mission_id, stamp=t + points * 60.0,
                                 kind='summary', state='', detail='done'), site=site)
            total += 1
    return total


def local_rows(path):
    """Every row of a store as the server should hold it: {table: {id: row}}."""
    import sqlite3
    from network_pkg.outbox import WIRE_COLUMNS, _wire_row
    conn = sqlite3.connect(path)
    out = {}
    for table, columns in WIRE_COLUMNS.items():
        rows = conn.execute('SELECT %s FROM %s' % (', '.join(columns), table)).fetchall()
        out[table] = dict((r[0], _wire_row(table, dict(zip(columns, r)))) for r in rows)
    conn.close()
    return out


def pending(path):
    import sqlite3
    conn = sqlite3.connect(path, timeout=10)
    try:
        return sum(conn.execute('SELECT COUNT(*) FROM %s WHERE uploaded = 0' % t).fetchone()[0]
                   for t in ('missions', 'observations', 'pick_records', 'events'))
    finally:
        conn.close()


def start_uploader(db_path, server_url, token, workdir, name, batch_size=50,
                   min_interval=0.0, backoff_initial=0.2, backoff_max=1.0, until_empty=False):
    log = open(os.path.join(workdir, 'uploader_%s.log' % name), 'ab')
    cmd = [sys.executable, '-m', 'network_pkg.outbox_cli', '--db', db_path, '--server',
           server_url, '--token=' + token, '--batch-size', str(batch_size), '--min-interval',
           str(min_interval), '--backoff-initial', str(backoff_initial), '--backoff-max',
           str(backoff_max), '--idle-period', '0.2', '--timeout', '5']
    if until_empty:
        cmd.append('--until-empty')
    proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=subprocess_env())
    log.close()
    return proc


def stop_process(proc, sig=signal.SIGTERM):
    if proc is not None and proc.poll() is None:
        proc.send_signal(sig)
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


# ------------------------------------------------------------------------- demo farm

def demo_farm(store_paths, t0, days=8, points=18, seed=3):
    """Robots taking turns on one row for ``days`` days: fruit ripening linearly, at most two
    picked per point and visit (so ripe fruit builds up). ``store_paths``: {robot: path}.
    Returns the local (UTC) date of the day after the last one.
    """
    rng = random.Random(seed)
    fruits = []
    for k in range(points):
        for _ in range(rng.choice([2, 4, 6, 8, 10]) if k % 9 else 0):
            fruits.append(dict(point=k, pos=(0.55 + rng.uniform(-0.1, 0.1),
                                             rng.uniform(-0.22, 0.22),
                                             0.85 + rng.uniform(0.0, 0.25)),
                               s0=rng.uniform(-0.3, 0.8), rate=rng.uniform(0.05, 0.15),
                               picked=False))
    robots = sorted(store_paths)
    stores = dict((r, Store(p, synchronous='NORMAL')) for r, p in store_paths.items())
    try:
        for d in range(days):
            robot = robots[d % len(robots)]
            store = stores[robot]
            mission_id = '%s-day%d' % (robot, d)
            t = t0 + d * DAY
            store.ensure_mission(mission_id, started=t, site='row1')
            for k in range(points):
                seen = [f for f in fruits if f['point'] == k and not f['picked']
                        and f['s0'] + f['rate'] * d >= 0.0]
                obs = [tomato(i, f['pos'], round(min(1.0, f['s0'] + f['rate'] * d), 3),
                              t + 60.0 * k) for i, f in enumerate(seen)]
                if obs:
                    store.add_observations(mission_id, k, 0.5 * k, obs, site='row1')
                ripe = [(i, f, o) for i, (f, o) in enumerate(zip(seen, obs))
                        if o['ripeness_score'] >= 0.7]
                for i, f, o in ripe[:2]:
                    ok = rng.random() < 0.8
                    f['picked'] = ok
                    store.add_pick_record(pick(mission_id, k, i, o['position'],
                                               t + 60.0 * k + 20.0 + i,
                                               outcome=0 if ok else 1,
                                               cycle_time=rng.uniform(22.0, 40.0)))
            store.end_mission(mission_id, t + 60.0 * points + 600.0, 'day %d done' % d)
    finally:
        for s in stores.values():
            s.close()
    return (datetime.datetime.fromtimestamp(t0, tz=datetime.timezone.utc).date()
            + datetime.timedelta(days=days))


def chromium():
    for name in ('chromium', 'chromium-browser', 'google-chrome'):
        path = shutil.which(name)
        if path:
            return path
    return None


def chromium_run(url, workdir, extra, timeout=60):
    profile = tempfile.mkdtemp(prefix='net_chromium_', dir=workdir)
    cmd = [chromium()] + CHROMIUM_FLAGS + ['--user-data-dir=%s' % profile] + extra + [url]
    result = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            timeout=timeout)
    shutil.rmtree(profile, ignore_errors=True)
    return result


def screenshot(out_path, workdir=None):
    """Run a demo farm (two robots, eight days), serve it and screenshot the page."""
    from farm_server.db import FarmDB
    workdir = workdir or tempfile.mkdtemp(prefix='net_shot_')
    db_url = 'sqlite:///' + os.path.join(workdir, 'farm.db')
    db = FarmDB(db_url)
    tokens = dict((r, db.add_robot(r)) for r in ('robot_a', 'robot_b'))
    db.dispose()
    t0 = time.time() - 8 * DAY
    paths = dict((r, os.path.join(workdir, '%s.db' % r)) for r in tokens)
    day = demo_farm(paths, t0, days=8)
    server = FarmServer(db_url, workdir).start()
    try:
        for r, p in paths.items():
            proc = start_uploader(p, server.url, tokens[r], workdir, r, batch_size=500,
                                  until_empty=True)
            proc.wait(60)
        result = chromium_run('%s/?day=%s' % (server.url, day.isoformat()), workdir,
                              ['--window-size=1200,860', '--virtual-time-budget=8000',
                               '--screenshot=%s' % os.path.abspath(out_path)])
        return result
    finally:
        server.stop()


if __name__ == '__main__':
    if len(sys.argv) == 3 and sys.argv[1] == 'screenshot':
        res = screenshot(sys.argv[2])
        sys.stdout.write(res.stderr.decode()[-500:])
    else:
        sys.stderr.write(__doc__)
        sys.exit(2)
