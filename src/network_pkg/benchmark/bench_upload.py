#!/usr/bin/env python3
"""Upload throughput: a robot's store drained into a real farm server process on loopback.

    python src/network_pkg/benchmark/bench_upload.py [--rows 6000] [--batch-sizes 50,200,1000]
                                                     [--postgres]

For each batch size: a fresh robot store (database_pkg.store, mostly observations, the mix of a
mission), a fresh server database, then network_pkg.outbox.Uploader (the node's logic, with
HTTP keep-alive) drains it. Prints rows/s and ms per batch. --postgres also runs against a
private PostgreSQL cluster (started and removed by the script).
"""
import argparse
import os
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'test'))

import farm_harness  # noqa: E402  (also puts the package sources on sys.path)
from farm_server.db import FarmDB  # noqa: E402
from network_pkg.outbox import Backoff, FarmClient, Outbox, Uploader  # noqa: E402


def fill(path, rows):
    """About ``rows`` rows: scans of 20 tomatoes with 2 pick records and 1 event each."""
    points = max(1, rows // 23)
    return farm_harness.fill_store(path, 1, missions=1, points=points, fruit=20)


def run(db_url, batch_size, rows, work):
    db = FarmDB(db_url)
    token = db.add_robot('bench')
    db.dispose()
    store = os.path.join(work, 'robot_%d_%s.db' % (batch_size, 'pg' if 'postgres' in db_url
                                                   else 'sqlite'))
    total = fill(store, rows)
    server = farm_harness.FarmServer(db_url, work).start()
    try:
        outbox = Outbox(store)
        client = FarmClient(server.url, token, timeout=30.0)
        up = Uploader(outbox, client, batch_size=batch_size, backoff=Backoff(0.1, 1.0))
        start = time.perf_counter()
        while not up.status()['drained']:
            up.step()
        elapsed = time.perf_counter() - start
        status = up.status()
        client.close()
        outbox.close()
    finally:
        server.stop()
    assert status['sent'] >= total and status['failures'] == 0, status
    return status['sent'], status['batches'], elapsed


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--rows', type=int, default=6000)
    parser.add_argument('--batch-sizes', default='50,200,500,1000')
    parser.add_argument('--postgres', action='store_true')
    args = parser.parse_args()
    sizes = [int(v) for v in args.batch_sizes.split(',')]
    work = tempfile.mkdtemp(prefix='net_bench_')
    backends = [('sqlite', lambda n: 'sqlite:///%s/farm_%d.db' % (work, n))]
    cluster = None
    if args.postgres:
        cluster = farm_harness.PostgresCluster().start()
        backends.append(('postgresql', lambda n: cluster.create_database('bench_%d' % n)))
    print('%-11s %6s %7s %8s %9s %11s' % ('backend', 'batch', 'rows', 'time s', 'rows/s',
                                         'ms/batch'))
    try:
        for name, make_url in backends:
            for n, size in enumerate(sizes):
                sent, batches, elapsed = run(make_url(n), size, args.rows, work)
                print('%-11s %6d %7d %8.2f %9.0f %11.1f' % (name, size, sent, elapsed,
                                                            sent / elapsed,
                                                            1000.0 * elapsed / batches))
                sys.stdout.flush()
    finally:
        if cluster is not None:
            cluster.stop()


if __name__ == '__main__':
    main()
