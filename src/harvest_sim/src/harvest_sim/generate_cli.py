"""Command line of scripts/generate_scenario (no rospy; works without a ROS master)."""

import argparse
import os
import sys

import yaml

from harvest_sim import scenario as scn

HERE = os.path.dirname(os.path.abspath(__file__))


def default_robot_config():
    """robot.yaml of harvest_description: via rospkg, else next to this source tree."""
    try:
        import rospkg
        return os.path.join(rospkg.RosPack().get_path('harvest_description'), 'config',
                            'robot.yaml')
    except Exception:      # noqa: BLE001 - no ROS environment: use the source tree
        return os.path.join(HERE, '..', '..', '..', 'harvest_description', 'config', 'robot.yaml')


def default_scenarios_dir():
    return os.path.normpath(os.path.join(HERE, '..', '..', 'scenarios'))


def parse_args(argv):
    p = argparse.ArgumentParser(
        description='Generate a harvest_sim scenario deterministically from a seed and knobs.',
        epilog='Knobs (with defaults): ' + ', '.join(
            '%s=%s' % (k, v) for k, v in scn.DEFAULT_KNOBS.items() if k != 'description'))
    p.add_argument('--preset', choices=list(scn.PRESETS), help='start from a shipped scenario')
    p.add_argument('--all-presets', action='store_true',
                   help='write every preset to --out-dir (regenerates the shipped scenarios)')
    p.add_argument('--seed', type=int, help='random seed (overrides the preset)')
    p.add_argument('--knob', action='append', default=[], metavar='NAME=YAML',
                   help='set a knob, e.g. --knob fruit_per_view=[0,8] --knob occlusion=0.5')
    p.add_argument('-o', '--output', help='output file (default: stdout)')
    p.add_argument('--out-dir', default=default_scenarios_dir(),
                   help='directory for --all-presets (default: the package scenarios/)')
    p.add_argument('--robot-config', default=None, help="robot.yaml (default: harvest_description's)")
    return p.parse_args(argv)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    from motion_pkg.kinematics import RobotGeometry
    geom = RobotGeometry.from_yaml(args.robot_config or default_robot_config())
    if args.all_presets:
        for name in scn.PRESETS:
            path = os.path.join(args.out_dir, name + '.yaml')
            s = scn.generate(scn.knobs_for(name), geom)
            scn.save_scenario(s, path)
            sys.stderr.write('%s: %d picking points, %d fruit (%d ripe and reachable)\n' % (
                path, len(s.track.picking_points), len(s.fruits),
                sum(1 for f in s.fruits if f.ripe and f.reachable)))
        return 0
    overrides = {}
    for item in args.knob:
        if '=' not in item:
            sys.stderr.write('--knob needs NAME=VALUE, got %r\n' % item)
            return 2
        key, value = item.split('=', 1)
        overrides[key.strip()] = yaml.load(value, Loader=yaml.SafeLoader)
    if args.seed is not None:
        overrides['seed'] = args.seed
    try:
        knobs = scn.knobs_for(args.preset, **overrides)
    except KeyError as e:
        sys.stderr.write('%s\n' % e.args[0])
        return 2
    s = scn.generate(knobs, geom)
    text = scn.dump_scenario(s)
    if args.output:
        with open(args.output, 'w') as f:
            f.write(text)
    else:
        sys.stdout.write(text)
    return 0
