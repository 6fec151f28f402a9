"""Benchmark of the simulator (scripts/bench_sim): render cost, per-stage costs and the speed the
whole stack reaches.

1. Render cost, in this process: full re-renders of the stereo pair and the hand camera on a
   scenario (the pose changes every frame, so no cache helps), and the cost of a frame of a still
   scene (cached layer, noise, blur).
2. Stage costs (--profile), in this process, on a rendered pair: rospy (de)serialisation of a
   1024x768 bgr8 Image and of stereo_image_proc's 1024x768 XYZRGB PointCloud2, the stereo work
   of stereo_image_proc (rectification remaps, StereoBM with the robot's parameters, point
   cloud), the detector on the right image, the point-cloud decoding and localisation of
   image_processing, a tf2 lookup.
3. Whole-stack runs: for every --scales value a private master (free port) runs
   `harvest_bringup sim.launch` (its own controller port and serial number: harvest_sim.instance) (simulated plant factory + the whole robot stack) on --scenario
   to the end of the mission; prints the speed reached (simulated / wall seconds from the first
   /clock tick to the mission summary), the mission's result from the simulator's ground truth
   and the executive's mean cycle time. With --profile, the run at --profile-scale also prints
   the CPU share of every node and the frames each stage handled (from ROS topic statistics),
   hence CPU ms per frame.
4. --sim-only: the older live run of sim_robot.launch alone (robot still, then moving).
This is a tool, not a node: it waits in wall time (rospy.rostime.wallsleep) and reads /proc.

Modules: this one is the command line (main); the measurements are in bench_costs (1, 2) and
bench_runs (3, 4), the report lines and the profile table in bench_report; their names are
re-exported here.
"""

import argparse
import os
import sys

import numpy as np

# re-exported: every bench.<name> keeps working
from harvest_sim.bench_costs import render_cost, stage_costs  # noqa: F401
from harvest_sim.bench_report import (  # noqa: F401
    FRAME_TOPICS, PROFILE_ROWS, print_profile, run_line)
from harvest_sim.bench_runs import live_run, stack_run  # noqa: F401


def main(argv=None):
    p = argparse.ArgumentParser(description='Simulator benchmark (prints figures).')
    p.add_argument('--scenario', default='default', help='scenario of the whole-stack runs')
    p.add_argument('--scales', default='2,5,10,20',
                   help='time scales of the whole-stack runs (comma separated; "" for none)')
    p.add_argument('--wall-limit', type=float, default=600.0,
                   help='wall seconds per whole-stack run')
    p.add_argument('--profile', action='store_true',
                   help='stage costs in this process and the per-node table of one run')
    p.add_argument('--profile-scale', type=float, default=5.0)
    p.add_argument('--launch-arg', action='append', default=[],
                   help='extra sim.launch argument NAME:=VALUE (repeatable)')
    p.add_argument('--frames', type=int, default=10, help='frames per camera for render cost')
    p.add_argument('--render-scenario', default='three_targets')
    p.add_argument('--no-render', action='store_true', help='skip the render cost')
    p.add_argument('--save-image', default=None, help='write the first left stereo frame here')
    p.add_argument('--sim-only', action='store_true',
                   help='live run of sim_robot.launch alone (robot still, then moving)')
    p.add_argument('--seconds', type=float, default=20.0, help='wall seconds of --sim-only')
    p.add_argument('--time-scale', type=float, default=5.0, help='time scale of --sim-only')
    p.add_argument('--controller', action='store_true',
                   help='--sim-only: the simulated Modbus controller instead of moving joints')
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    print('machine: %d CPU cores, load average %.2f %.2f %.2f (shared machine: other jobs '
          'inflate these figures)' % ((os.cpu_count() or 0,) + os.getloadavg()))
    sys.stdout.flush()
    if not args.no_render:
        r = render_cost(args.render_scenario, args.frames, args.save_image)
        print('render (%s): renderer set-up %.0f ms; new view, stereo eye 1024x768: mean '
              '%.1f ms, median %.1f ms; hand 640x480: mean %.1f ms, median %.1f ms; still '
              'scene (cached), stereo eye: median %.1f ms'
              % (args.render_scenario, r['init_ms'], np.mean(r['stereo_ms']),
                 np.median(r['stereo_ms']), np.mean(r['hand_ms']), np.median(r['hand_ms']),
                 r['cached_ms']))
        if args.save_image:
            print('saved %s' % args.save_image)
    if args.profile:
        print('stage costs, median ms in this process (%s):' % args.render_scenario)
        for k, v in stage_costs(args.render_scenario).items():
            print('  %-58s %s' % (k, ('%.2f' % v) if isinstance(v, float) else v))
    sys.stdout.flush()
    if args.sim_only:
        for res in live_run(args.render_scenario, args.seconds, args.time_scale,
                            args.controller):
            what = {'still': 'robot still', 'moving': 'cart and left arm moving'}[res['phase']]
            print('sim only, %s (time_scale %.1f): %.1f s simulated in %.1f s wall -> %.2f'
                  % (what, args.time_scale, res['sim'], res['wall'], res['scale']))
            print('  frames per simulated second: stereo pairs %.2f, hand %.2f, points2 %.2f'
                  % (res['rates']['stereo'], res['rates']['hand'], res['rates']['points2']))
            print('  CPU %% of one core: ' + ', '.join(
                '%s %.0f' % (k, v) for k, v in sorted(res['cpu'].items(), key=lambda kv: -kv[1])
                if v >= 0.5))
        return 0
    scales = [float(x) for x in args.scales.split(',') if x.strip()]
    if args.profile and args.profile_scale not in scales:
        scales.append(args.profile_scale)
    print('whole stack (harvest_bringup sim.launch, scenario %s), one mission per time scale:'
          % args.scenario)
    sys.stdout.flush()
    ok = True
    for scale in scales:
        profile = args.profile and scale == args.profile_scale
        res = stack_run(args.scenario, scale, args.wall_limit, profile, args.launch_arg)
        print(run_line(scale, res) + '  [load %.2f]' % os.getloadavg()[0])
        if profile and 'error' not in res:
            print_profile(res, scale)
        ok = ok and 'error' not in res and res['summary'].get('outcome') == 'succeeded'
        sys.stdout.flush()
    return 0 if ok else 1
