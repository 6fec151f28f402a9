"""Perception audit of the mission scenarios: every picking point over the stereo cameras' noise frames.

The simulated stereo head adds one of NOISE_FRAMES sensor-noise frames per eye to each image
(harvest_sim.render, `noise_key`), and which pair a mission's scan gets depends on how many frames
each camera has rendered by then. A fruit that is located well in one pair and badly in another
is a mission that passes or fails by timing. For each scenario and picking point this renders the
NOISE_FRAMES x NOISE_FRAMES (right, left) pairs offline, runs the detector, `locate_all` and
`regrade` as the image_processing node does, and prints one line per ripe reachable fruit of
that point that is not found pickable (score >= the pickable threshold) within `--tolerance` of
its centre in every pair, and one per point where an unripe fruit is taken for a pickable one:

  SCENARIO point P FRUIT: K of 16 off: r2l0:12 r2l1:13 ...   (pair: error in mm, or - for none)
  SCENARIO point P unripe taken ripe: FRUIT(ripeness) r0l1 ...

The ground truth (the scenario file) is read here, as benchmarks may; the robot stack never does.
Usage: tools/perception_audit.py [--scenario NAME ...] [--tolerance MM]
"""
import argparse
import glob
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCENARIOS = os.path.join(os.path.dirname(HERE), 'src', 'harvest_sim', 'scenarios')
ROBOT = os.path.join(os.path.dirname(HERE), 'src', 'harvest_description', 'config', 'robot.yaml')
#: noise frames per eye in harvest_sim's renderer (Renderer.noise_frames' default bank)
NOISE_FRAMES = 4
#: a score from this on is pickable (image_processing's ~min_ripeness default)
PICKABLE = 0.7
#: fruit farther than this (m) across the track from a picking point are not in its view
VIEW_HALF_WIDTH = 0.4
#: an unripe fruit this close (m) to a pickable location is taken for a pickable one
TAKEN_DISTANCE = 0.02


def nearest_errors(located, positions):
    """Per position (3-vectors, map frame), the distance (m) to the nearest located point, or
    None when nothing was located."""
    located = [np.asarray(p, dtype=float) for p in located]
    return [min(float(np.linalg.norm(np.asarray(q, dtype=float) - p)) for p in located)
            if located else None for q in positions]


def pair_label(kr, kl, error):
    return 'r%dl%d:%s' % (kr, kl, '-' if error is None else '%.0f' % (1000.0 * error))


def audit_point(scenario, point, renderer, fruits, geom, camera, detector, stereo,
                tolerance):
    """(off, taken) of one picking point: off = {fruit id: [pair labels where the fruit is not
    located pickable within tolerance]} for its ripe reachable fruit; taken = ['id(ripeness)
    rXlY', ...] of unripe fruit near a pickable location."""
    from harvest_sim import scenario as scn
    from vision_pkg import localisation
    y = scenario.track.picking_points[point]
    left_t, right_t = scn.stereo_eyes(geom, y)
    base = float(np.linalg.norm(left_t[:3, 3] - right_t[:3, 3]))
    p_right = camera.P(-camera.fx * base)             # the right eye's, as its camera_info
    want = [f for f in scenario.fruits if f.picking_point == point and f.ripeness >= PICKABLE and
            f.reachable]
    unripe = [f for f in scenario.fruits if abs(f.position[1] - y) < VIEW_HALF_WIDTH and
              f.ripeness < PICKABLE]
    off = dict((f.id, []) for f in want)
    taken = []
    lefts = [renderer.render(camera, left_t, fruits, noise_key=('left', k))
             for k in range(NOISE_FRAMES)]
    for kr in range(NOISE_FRAMES):
        right = renderer.render(camera, right_t, fruits, noise_key=('right', kr))
        detections = detector.detect(right)
        for kl, left in enumerate(lefts):
            cloud = localisation.offline_cloud(left, right, stereo, camera.fx, camera.fy,
                                               camera.cx, camera.cy, base)
            found = localisation.regrade(detector, cloud, list(zip(
                detections, localisation.locate_all(cloud, detections, p_right, image=right))),
                p_right, right)
            located = [left_t[:3, :3].dot(loc.centre) + left_t[:3, 3] for d, loc in found
                       if loc is not None and d.score >= PICKABLE]
            for f, e in zip(want, nearest_errors(located, [f.position for f in want])):
                if e is None or e > tolerance:
                    off[f.id].append(pair_label(kr, kl, e))
            for f, e in zip(unripe, nearest_errors(located, [f.position for f in unripe])):
                if e is not None and e < TAKEN_DISTANCE:
                    taken.append('%s(%.2f) r%dl%d' % (f.id, f.ripeness, kr, kl))
    return off, taken


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', action='append', help='scenario names (default: all)')
    parser.add_argument('--tolerance', type=float, default=12.0,
                        help='mm from the fruit centre within which a location counts (default 12)')
    args = parser.parse_args()
    from harvest_sim import camera_model, render
    from harvest_sim.scenario_yaml import load_scenario
    from motion_pkg.kinematics import RobotGeometry
    from vision_pkg.bench_config import load_detector, load_stereo_params
    names = args.scenario or sorted(os.path.splitext(os.path.basename(p))[0]
                                    for p in glob.glob(os.path.join(SCENARIOS, '*.yaml')))
    geom = RobotGeometry.from_yaml(ROBOT)
    detector, stereo = load_detector(None), load_stereo_params(None)
    camera = camera_model.stereo_camera()
    pairs = NOISE_FRAMES * NOISE_FRAMES
    flagged = 0
    for name in names:
        scenario = load_scenario(os.path.join(SCENARIOS, name + '.yaml'))
        renderer = render.Renderer(scenario)
        fruits = render.fruits_from_scenario(scenario)
        for point in range(len(scenario.track.picking_points)):
            off, taken = audit_point(scenario, point, renderer, fruits, geom, camera, detector,
                                     stereo, args.tolerance / 1000.0)
            for fid, labels in sorted(off.items()):
                if labels:
                    flagged += 1
                    print('%s point %d %s: %d of %d off: %s'
                          % (name, point, fid, len(labels), pairs, ' '.join(labels)))
            if taken:
                flagged += 1
                print('%s point %d unripe taken ripe: %s' % (name, point, ' '.join(taken)))
            sys.stdout.flush()
        print('%s: %d picking points audited' % (name, len(scenario.track.picking_points)))
        sys.stdout.flush()
    print('perception audit: %d finding(s) in %d scenario(s)' % (flagged, len(names)))
    return 0


if __name__ == '__main__':
    sys.exit(main())
