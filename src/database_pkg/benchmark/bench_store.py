"""Write cost of the local store: synchronous FULL vs NORMAL (prints figures, asserts nothing).

    python src/database_pkg/benchmark/bench_store.py [--n 200] [--dir /tmp]

One transaction per call, as the node does: a pick record, an event, and a scan of 10 tomatoes.
"""
import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'src'))
from database_pkg.store import Store  # noqa: E402


def observation(i):
    return dict(detection_id=i, position=(0.5, 0.1 * i, 0.9), frame_id='base_link', radius=0.03,
                ripeness_stage=3, ripeness_score=0.9, pickable=True, pick_order=i, stamp=1.0,
                image_id='img')


def record(i):
    return dict(mission_id='bench', picking_point=i, target_id=0, position=(0.5, 0.2, 0.9),
                frame_id='base_link', outcome=0, reason='', state_names=['A', 'B', 'C'],
                state_durations=[0.5, 1.5, 2.0], cycle_time=4.0, stamp=1.0 + i)


def timed(fn, n):
    samples = []
    for i in range(n):
        t0 = time.perf_counter()
        fn(i)
        samples.append((time.perf_counter() - t0) * 1e3)
    samples.sort()
    return statistics.median(samples), samples[int(0.95 * (len(samples) - 1))]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--n', type=int, default=200, help='transactions per case')
    parser.add_argument('--dir', default=None, help='directory of the temporary database')
    args = parser.parse_args()
    directory = tempfile.mkdtemp(prefix='bench_store_', dir=args.dir)
    try:
        for mode in ('NORMAL', 'FULL'):
            path = os.path.join(directory, mode + '.db')
            with Store(path, synchronous=mode) as s:
                scan = [observation(k) for k in range(10)]
                cases = (
                    ('pick record', lambda i: s.add_pick_record(record(i))),
                    ('event', lambda i: s.add_event(dict(mission_id='bench', stamp=1.0 + i,
                                                         kind='state', state='S', detail=''))),
                    ('scan of 10 tomatoes', lambda i: s.add_observations('bench', i, 0.1 * i,
                                                                         scan)),
                )
                for name, fn in cases:
                    median, p95 = timed(fn, args.n)
                    print('%-7s %-20s median %6.2f ms  p95 %6.2f ms  (%d transactions)'
                          % (mode, name, median, p95, args.n))
            print('%-7s file size after %d rows each: %d kB'
                  % (mode, args.n, os.path.getsize(path) // 1024))
    finally:
        shutil.rmtree(directory)


if __name__ == '__main__':
    main()
