"""Command line of the farm server (``rosrun farm_server farm_server ...`` or
``python -m farm_server ...``).

    farm_server [--db URL] serve [--host 127.0.0.1] [--port 8420] [--config FILE]
                                 [--ssl-certfile F --ssl-keyfile F] [--log-level info] [--access-log]
    farm_server token add ROBOT [--token T]     prints the robot's new token
    farm_server token remove ROBOT
    farm_server token list
    farm_server migrate                         create / upgrade the schema and exit
    farm_server                                 same as `farm_server serve`

Database: ``--db``, else the environment variable FARM_DB_URL, else the embedded SQLite file
``~/.ros/harvest/farm_server.db``. PostgreSQL: ``--db postgresql://USER:PASS@HOST:PORT/DB``.

Config file (YAML, all optional):
    server:  {max_batch_rows: 1000, max_body_bytes: 8388608, fusion_cache: 8}
    fusion:  {match_tolerance: 0.05, ripe_score: 0.7, default_rate: 0.07, ...}
    robots:  {robot_a: TOKEN, robot_b: TOKEN}   # registered (hashed) at start
"""

import argparse
import logging
import os
import sys

import yaml

__all__ = ['main', 'build_parser', 'load_config']

DEFAULT_PORT = 8420


def load_config(path):
    if not path:
        return {}
    with open(path) as f:
        data = yaml.load(f, Loader=yaml.SafeLoader) or {}
    if not isinstance(data, dict):
        raise ValueError('%s: the config must be a mapping' % path)
    unknown = set(data) - {'server', 'fusion', 'robots'}
    if unknown:
        raise ValueError('%s: unknown section(s) %s (known: server, fusion, robots)'
                         % (path, ', '.join(sorted(unknown))))
    return data


def build_parser():
    parser = argparse.ArgumentParser(prog='farm_server', description=__doc__.split('\n')[0])
    parser.add_argument('--db', default=None, help='SQLAlchemy URL (default: $FARM_DB_URL or '
                        'sqlite:///~/.ros/harvest/farm_server.db)')
    sub = parser.add_subparsers(dest='command')
    serve = sub.add_parser('serve', help='run the HTTP server')
    serve.add_argument('--host', default='127.0.0.1', help='bind address (default loopback)')
    serve.add_argument('--port', type=int, default=DEFAULT_PORT)
    serve.add_argument('--config', default=None, help='YAML config file')
    serve.add_argument('--ssl-certfile', default=None)
    serve.add_argument('--ssl-keyfile', default=None)
    serve.add_argument('--log-level', default='info',
                       choices=['critical', 'error', 'warning', 'info', 'debug'])
    serve.add_argument('--access-log', action='store_true', help='log every request')
    token = sub.add_parser('token', help='manage per-robot tokens')
    token_sub = token.add_subparsers(dest='token_command')
    add = token_sub.add_parser('add', help='register a robot (or renew its token)')
    add.add_argument('robot')
    add.add_argument('--token', default=None, help='use this token instead of a random one')
    remove = token_sub.add_parser('remove', help='revoke a robot\'s token')
    remove.add_argument('robot')
    token_sub.add_parser('list', help='list robots')
    sub.add_parser('migrate', help='create or upgrade the schema, then exit')
    return parser


def _open_db(args):
    from farm_server.db import FarmDB
    return FarmDB(args.db or os.environ.get('FARM_DB_URL') or None)


def main(argv=None):
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    args = parser.parse_args(argv)
    if args.command is None:    # no command: serve with the defaults
        args = parser.parse_args(argv + ['serve'])
    if args.command == 'token' and args.token_command is None:
        parser.error('token needs a sub-command: add, remove or list')
    logging.basicConfig(level=logging.INFO, format='%(asctime)s %(name)s %(levelname)s '
                                                   '%(message)s')
    try:
        db = _open_db(args)
    except Exception as e:  # noqa: broad on purpose, the message names the cause
        sys.stderr.write('farm_server: cannot open the database: %s\n' % e)
        return 1
    try:
        if args.command == 'migrate':
            print('schema version %d at %s' % (db.schema_version(), db.safe_url()))
            return 0
        if args.command == 'token':
            if args.token_command == 'add':
                print(db.add_robot(args.robot, args.token))
            elif args.token_command == 'remove':
                if not db.remove_robot(args.robot):
                    sys.stderr.write('farm_server: no robot %s\n' % args.robot)
                    return 1
            else:
                for r in db.robots():
                    print('%s\tuploads=%d\trows=%d' % (r['name'], r['uploads'],
                                                       r['rows_received']))
            return 0
        return _serve(args, db)
    finally:
        db.dispose()


def _serve(args, db):
    import uvicorn
    from farm_server.app import ServerSettings, create_app
    from farm_server.fusion import FusionConfig
    try:
        config = load_config(args.config)
        settings = ServerSettings(**(config.get('server') or {}))
        fusion_cfg = FusionConfig(**(config.get('fusion') or {}))
    except (OSError, ValueError, yaml.YAMLError) as e:
        sys.stderr.write('farm_server: bad config: %s\n' % e)
        return 1
    for name, token in (config.get('robots') or {}).items():
        db.add_robot(str(name), str(token))
    app = create_app(db, fusion_cfg, settings)
    logging.getLogger('farm_server').info('serving %s on %s:%d', db.safe_url(), args.host,
                                          args.port)
    uvicorn.run(app, host=args.host, port=args.port, log_level=args.log_level,
                access_log=args.access_log, ssl_certfile=args.ssl_certfile,
                ssl_keyfile=args.ssl_keyfile)
    return 0
