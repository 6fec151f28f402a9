"""The detection benchmark's rendered frames, rospy-free: the sweep of the scenario generator's
difficulty knobs, stereo pairs rendered by harvest_sim at every picking point and cached on disk,
and each frame's ground truth (every fruit's exact sphere silhouette box in the right eye, its
visible fraction from the renderer's label image, its centre in both eyes). Used by
vision_pkg.bench (definitions in its docstring).
"""
import json
import math
import os

import cv2
import numpy as np

from vision_pkg.bench_config import _package_dir

#: knob sets swept by the benchmark (cycled over the scenarios)
SWEEP = (
    dict(fruit_per_view=[0, 3], cluster_density=0.2, occlusion=0.0, intensity=1.0),
    dict(fruit_per_view=[2, 5], cluster_density=0.5, occlusion=0.2, intensity=1.0,
         lighting_variation=0.3),
    dict(fruit_per_view=[5, 8], cluster_density=1.0, occlusion=0.4, intensity=1.0,
         leaves_per_view=9),
    dict(fruit_per_view=[3, 6], cluster_density=0.7, occlusion=0.3, intensity=0.4,
         ambient=0.25, light_colour=[1.0, 0.85, 0.7], light_direction=[0.2, 0.6, -0.6]),
    dict(fruit_per_view=[2, 6], cluster_density=0.5, occlusion=0.6, intensity=1.3,
         lighting_variation=0.5, borderline_fraction=0.2),
    dict(fruit_per_view=[6, 8], cluster_density=0.8, occlusion=0.2, intensity=0.7,
         lighting_variation=0.3, borderline_fraction=0.1),
)


def silhouette_box(camera, centre_cam, radius):
    """(x0, y0, x1, y1) of a sphere's exact silhouette in an ideal pinhole camera."""
    c = np.asarray(centre_cam, dtype=float)
    dist = np.linalg.norm(c)
    d = c / dist
    e1 = np.cross(d, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    a = np.linspace(0.0, 2.0 * math.pi, 180, endpoint=False)
    off = dist - radius * radius / dist
    rad = radius * math.sqrt(max(1.0 - (radius / dist) ** 2, 0.0))
    pts = d * off + rad * (np.outer(np.cos(a), e1) + np.outer(np.sin(a), e2))
    uv = camera.project(pts)
    return float(uv[:, 0].min()), float(uv[:, 1].min()), float(uv[:, 0].max()), \
        float(uv[:, 1].max())


def render_frames(count, cache_dir, seed, log):
    """Yield (frame dict) for `count` frames, rendering missing ones into cache_dir."""
    from harvest_sim import camera_model, render, scenario as scn
    from motion_pkg.kinematics import RobotGeometry
    geom = None
    camera = camera_model.stereo_camera()
    os.makedirs(cache_dir, exist_ok=True)
    produced = 0
    index = 0
    current = None       # (scenario, renderer, render fruits) of the scenario being rendered
    while produced < count:
        knobs = dict(SWEEP[index % len(SWEEP)])
        knobs.update(name='bench_%03d' % index, seed=seed * 1000 + index, picking_points=8,
                     spacing=0.6, unreachable_fraction=0.2)
        for point in range(8):
            if produced >= count:
                break
            stem = os.path.join(cache_dir, 'bench_%03d_%d' % (index, point))
            if not os.path.exists(stem + '.json'):
                if geom is None:
                    robot_yaml = os.path.join(_package_dir(), '..', 'harvest_description',
                                              'config', 'robot.yaml')
                    try:
                        import rospkg
                        robot_yaml = os.path.join(rospkg.RosPack().get_path('harvest_description'),
                                                  'config', 'robot.yaml')
                    except Exception:
                        pass
                    geom = RobotGeometry.from_yaml(robot_yaml)
                if current is None or current[0].name != knobs['name']:
                    sc = scn.generate(knobs, geom)
                    current = (sc, render.Renderer(sc), render.fruits_from_scenario(sc))
                sc, renderer, fruits = current
                y = sc.track.picking_points[point]
                left_T, right_T = scn.stereo_eyes(geom, y)
                right, labels = renderer.render(camera, right_T, fruits,
                                                noise_key=('stereo_right', point), labels=True)
                left = renderer.render(camera, left_T, fruits, noise_key=('stereo_left', point))
                gt = []
                for i, f in enumerate(sc.fruits):
                    pr = camera_model.to_camera(right_T, f.position)[0]
                    pl = camera_model.to_camera(left_T, f.position)[0]
                    if pr[2] <= f.radius + 0.02:
                        continue
                    x0, y0, x1, y1 = silhouette_box(camera, pr, f.radius)
                    if x1 < 0 or y1 < 0 or x0 > camera.width - 1 or y0 > camera.height - 1:
                        continue
                    area = math.pi * (x1 - x0) * (y1 - y0) / 4.0
                    visible = float((labels == i + 1).sum()) / max(area, 1.0)
                    gt.append(dict(id=f.id, ripeness=f.ripeness, radius=f.radius,
                                   box=[x0, y0, x1, y1], centre_left=pl.tolist(),
                                   centre_right=pr.tolist(), visible=min(visible, 1.0)))
                cv2.imwrite(stem + '_r.png', right)
                cv2.imwrite(stem + '_l.png', left)
                meta = dict(fx=camera.fx, fy=camera.fy, cx=camera.cx, cy=camera.cy,
                            baseline=float(np.linalg.norm(left_T[:3, 3] - right_T[:3, 3])),
                            knobs={k: v for k, v in knobs.items()}, fruits=gt)
                with open(stem + '.json', 'w') as handle:
                    json.dump(meta, handle)
                log('rendered %s (%d fruit in view)' % (os.path.basename(stem), len(gt)))
            with open(stem + '.json') as handle:
                meta = json.load(handle)
            meta['right'] = cv2.imread(stem + '_r.png')
            meta['left'] = cv2.imread(stem + '_l.png')
            meta['name'] = os.path.basename(stem)
            produced += 1
            yield meta
        index += 1
