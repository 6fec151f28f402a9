#!/usr/bin/env python3
"""Cost of the camera look (harvest_sim/look.py) per frame, on one core.

    python bench_look.py [--frames 60] [--scenario three_targets]

Renders one stereo frame and one hand frame of the scenario without the look, then applies the
look of every kind to them `--frames` times (with sensor noise, cycling the noise bank) with
OpenCV limited to one thread, and prints the CPU time (time.process_time, so other load on the
machine counts less) per frame: median and minimum. The one-off set-up (LUTs, vignetting map,
noise bank) is timed separately. Prints; asserts nothing.
"""

import argparse
import os
import sys
import time

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.normpath(os.path.join(HERE, '..'))
for p in (os.path.join(PKG, 'src'), os.path.join(PKG, '..', 'motion_pkg', 'src')):
    if p not in sys.path:
        sys.path.insert(0, p)

from harvest_sim import camera_model, look, render, scenario as scn  # noqa: E402
from motion_pkg.kinematics import RobotGeometry  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--frames', type=int, default=60)
    ap.add_argument('--scenario', default='three_targets')
    a = ap.parse_args(argv)
    cv2.setNumThreads(1)
    geom = RobotGeometry.from_yaml(os.path.join(PKG, '..', 'harvest_description', 'config',
                                                'robot.yaml'))
    s = scn.load_scenario(scn.resolve_scenario(a.scenario, os.path.join(PKG, 'scenarios')))
    clean = render.Renderer(s, look=False)
    fr = render.fruits_from_scenario(s)
    poses = render.camera_poses(geom, {'cart_joint': s.track.picking_points[0]})
    frames = [(camera_model.stereo_camera(), clean.render(camera_model.stereo_camera(),
                                                           poses['stereo_left_optical'], fr)),
              (camera_model.hand_camera(), clean.render(camera_model.hand_camera(),
                                                         poses['hand_camera_optical'], fr))]
    print('camera look cost per frame, one core (OpenCV 1 thread), CPU ms, %d frames each'
          % a.frames)
    for cam, img in frames:
        for kind in look.KINDS:
            t0 = time.process_time()
            params = look.look_params(s.seed, look.camera_key(cam), kind)
            cl = look.CameraLook(params, cam.width, cam.height)
            bank = look.noise_bank(s.seed, 'bench', cam.width, cam.height)
            setup = (time.process_time() - t0) * 1000.0
            cl.apply(img, bank[0])
            cost = []
            for i in range(a.frames):
                t = time.process_time()
                cl.apply(img, bank[i % len(bank)])
                cost.append((time.process_time() - t) * 1000.0)
            print('  %4dx%-4d %-8s median %5.2f ms  min %5.2f ms  (set-up once %4.0f ms)'
                  % (cam.width, cam.height, kind, np.median(cost), min(cost), setup))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
