"""The uploader without ROS: drain a robot's store into the farm server from a shell.

    python -m network_pkg.outbox_cli --db ~/.ros/harvest/harvest.db \
        --server http://127.0.0.1:8420 --token-file robot.token [--until-empty]

Same logic as the ROS node (network_pkg.outbox.Uploader); used by the tests and for manual
catch-up uploads (e.g. a robot's database copied off a broken robot). Stops on SIGINT/SIGTERM.
"""

import argparse
import os
import signal
import sys
import threading

from network_pkg.outbox import Backoff, FarmClient, Outbox, Uploader

__all__ = ['main']


def read_token(token, token_file):
    if token:
        return token
    if token_file:
        with open(os.path.expanduser(token_file)) as f:
            return f.read().strip()
    return os.environ.get('FARM_TOKEN', '')


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--db', required=True, help='the robot\'s store (SQLite file)')
    parser.add_argument('--server', default='http://127.0.0.1:8420')
    parser.add_argument('--token', default=None)
    parser.add_argument('--token-file', default=None, help='file holding the token '
                        '(default: --token, else $FARM_TOKEN)')
    parser.add_argument('--batch-size', type=int, default=200)
    parser.add_argument('--timeout', type=float, default=10.0)
    parser.add_argument('--backoff-initial', type=float, default=1.0)
    parser.add_argument('--backoff-max', type=float, default=60.0)
    parser.add_argument('--min-interval', type=float, default=0.0,
                        help='pause between batches [s] (link sharing)')
    parser.add_argument('--idle-period', type=float, default=2.0)
    parser.add_argument('--until-empty', action='store_true', help='exit 0 once drained')
    parser.add_argument('--ca-file', default=None, help='CA bundle for an https server')
    args = parser.parse_args(argv)

    token = read_token(args.token, args.token_file)
    if not token:
        sys.stderr.write('outbox_cli: no token (--token, --token-file or $FARM_TOKEN)\n')
        return 2
    outbox = Outbox(os.path.expanduser(args.db))
    client = FarmClient(args.server, token, timeout=args.timeout,
                        verify=args.ca_file if args.ca_file else True)
    uploader = Uploader(outbox, client, batch_size=args.batch_size,
                        backoff=Backoff(args.backoff_initial, args.backoff_max),
                        idle_period=args.idle_period, min_interval=args.min_interval)
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_a: stop.set())
    signal.signal(signal.SIGINT, lambda *_a: stop.set())
    last_error = ''
    try:
        while not stop.is_set():
            delay = uploader.step()
            status = uploader.status()
            if status['last_error'] != last_error and status['last_error']:
                last_error = status['last_error']
                sys.stderr.write('outbox_cli: %s (retry in %.1f s)\n' % (last_error, delay))
            if args.until_empty and status['drained']:
                break
            if delay > 0:
                stop.wait(delay)
    finally:
        client.close()
        outbox.close()
    status = uploader.status()
    sys.stdout.write('sent %d rows in %d batches (%d already on the server)\n'
                     % (status['sent'], status['batches'], status['duplicates']))
    return 0


if __name__ == '__main__':
    sys.exit(main())
