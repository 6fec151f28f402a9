"""Benchmark of the tomato detector, grader and 3D localisation on harvest_sim frames (no ROS).

Frames: stereo pairs rendered by harvest_sim's renderer at every picking point of generated
scenarios that sweep the generator's difficulty knobs (fruit per view 0-8, cluster density,
occlusion by leaves, light intensity/colour/direction). Rendered pairs are cached on disk
(--cache-dir) so reruns only measure.

Ground truth per frame: every scenario fruit projected into the right eye (box of the exact
sphere silhouette, clipped to the image) with its visible fraction from the renderer's label
image. A fruit must be found ("care") when at least --min-visible of its silhouette is
visible; less visible fruit are "don't care": detections matched to them count neither way.

Figures:
  * ripe-fruit detection: a detection is "ripe" when its score >= --min-ripeness; TP when it
    matches (IoU >= 0.5, greedy one-to-one over all detections and fruit) a care fruit with
    ripeness >= 0.7; FP when it matches an unripe fruit or nothing; FN a care ripe fruit
    without a matching ripe detection. Precision, recall, F1.
  * stage accuracy over all matched care fruit (green/turning/pink/red), and the confusion.
  * 3D pick-point error of matched ripe fruit: the cloud is recomputed offline with cv2.StereoBM
    configured from config/stereo_image_proc.yaml on the rendered (already rectified) pair,
    exactly as stereo_image_proc would; error = |estimated centre - true centre|, median and
    p95, overall and for true depth 0.4-0.8 m.
  * detection CPU time (time.process_time, so other load on the machine does not count) per
    1024x768 frame on one core (cv2.setNumThreads(1)), and wall time of localisation and of
    the offline StereoBM.
"""
import argparse
import json
import math
import os
import time

import cv2
import numpy as np
import yaml

from vision_pkg import localisation
from vision_pkg.detection import STAGE_NAMES, TomatoDetector, stage_of

RIPE = 0.7
IOU_MIN = 0.5

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


def _package_dir():
    try:
        import rospkg
        return rospkg.RosPack().get_path('vision_pkg')
    except Exception:       # rospkg missing or package not on ROS_PACKAGE_PATH: source tree
        return os.path.abspath(os.path.join(os.path.dirname(__file__), '..', '..'))


def load_stereo_params(path=None):
    path = path or os.path.join(_package_dir(), 'config', 'stereo_image_proc.yaml')
    with open(path) as handle:
        return yaml.load(handle, Loader=yaml.SafeLoader)


def load_detector(path=None):
    path = path or os.path.join(_package_dir(), 'config', 'image_processing.yaml')
    with open(path) as handle:
        cfg = yaml.load(handle, Loader=yaml.SafeLoader) or {}
    return TomatoDetector(**cfg.get('stereo_detection', {}))


# ------------------------------------------------------------------------------ frames
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
                    robot_yaml = os.path.join(_package_dir(), '..', 'visualization_pkg',
                                              'config', 'robot.yaml')
                    try:
                        import rospkg
                        robot_yaml = os.path.join(rospkg.RosPack().get_path('visualization_pkg'),
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


# ------------------------------------------------------------------------------ metrics
def iou(a, b):
    ix = max(0.0, min(a[2], b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[3], b[3]) - max(a[1], b[1]))
    inter = ix * iy
    union = (a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - inter
    return inter / union if union > 0 else 0.0


def clip_box(box, width, height):
    return [min(max(box[0], 0.0), width - 1.0), min(max(box[1], 0.0), height - 1.0),
            min(max(box[2], 0.0), width - 1.0), min(max(box[3], 0.0), height - 1.0)]


def match(det_boxes, gt_boxes):
    """Greedy one-to-one matching by IoU >= IOU_MIN: list of (det index, gt index)."""
    pairs = []
    for i, db in enumerate(det_boxes):
        for j, gb in enumerate(gt_boxes):
            v = iou(db, gb)
            if v >= IOU_MIN:
                pairs.append((v, i, j))
    pairs.sort(reverse=True)
    used_d, used_g, out = set(), set(), []
    for _, i, j in pairs:
        if i not in used_d and j not in used_g:
            used_d.add(i)
            used_g.add(j)
            out.append((i, j))
    return out


def run(args, log=print):
    cv2.setNumThreads(1)
    detector = load_detector(args.config)
    stereo = load_stereo_params(args.stereo_config)
    tp = fp = fn = ignored = 0
    stage_total = stage_ok = 0
    confusion = np.zeros((4, 4), dtype=int)
    err_all, err_range = [], []
    no_point = 0
    det_ms, loc_ms, bm_ms = [], [], []
    frames = 0
    fp_log, fn_log = [], []
    detector.detect(np.zeros((768, 1024, 3), np.uint8))     # warm-up outside the timing
    for frame in render_frames(args.frames, args.cache_dir, args.seed, log):
        frames += 1
        right, left = frame['right'], frame['left']
        h, w = right.shape[:2]
        t0 = time.process_time()          # CPU time of this (single-threaded) process
        dets = detector.detect(right)
        det_ms.append((time.process_time() - t0) * 1000.0)
        gts = frame['fruits']
        gt_boxes = [clip_box(g['box'], w, h) for g in gts]
        det_boxes = []
        for d in dets:
            x, y, bw, bh = d.box(w, h)
            det_boxes.append([x, y, x + bw - 1.0, y + bh - 1.0])
        pairs = dict(match(det_boxes, gt_boxes))
        care = [g['visible'] >= args.min_visible for g in gts]
        matched_gt = set(pairs.values())
        cloud = None
        p_right = [frame['fx'], 0.0, frame['cx'], -frame['fx'] * frame['baseline'],
                   0.0, frame['fy'], frame['cy'], 0.0, 0.0, 0.0, 1.0, 0.0]
        for i, d in enumerate(dets):
            j = pairs.get(i)
            det_ripe = d.score >= args.min_ripeness
            if j is not None and not care[j]:
                continue
            if j is not None:
                g = gts[j]
                true_stage = stage_of(g['ripeness'])
                confusion[true_stage, d.stage] += 1
                stage_total += 1
                stage_ok += int(true_stage == d.stage)
            if not det_ripe:
                continue
            if j is None and any(not care[k] and gt_boxes[k][0] <= d.u <= gt_boxes[k][2] and
                                 gt_boxes[k][1] <= d.v <= gt_boxes[k][3]
                                 for k in range(len(gts))):
                ignored += 1          # on a mostly hidden fruit: neither TP nor FP
                continue
            if j is not None and gts[j]['ripeness'] >= RIPE:
                tp += 1
                if cloud is None:
                    t0 = time.perf_counter()
                    cloud = localisation.offline_cloud(left, right, stereo, frame['fx'],
                                                       frame['fy'], frame['cx'], frame['cy'],
                                                       frame['baseline'])
                    bm_ms.append((time.perf_counter() - t0) * 1000.0)
                t0 = time.perf_counter()
                loc = localisation.locate(cloud, d, p_right)
                loc_ms.append((time.perf_counter() - t0) * 1000.0)
                if loc is None:
                    no_point += 1
                    continue
                err = float(np.linalg.norm(loc.centre - np.array(gts[j]['centre_left'])))
                err_all.append(err)
                if 0.4 <= gts[j]['centre_left'][2] <= 0.8:
                    err_range.append(err)
            else:
                fp += 1
                fp_log.append('%s det %r matched %s' % (
                    frame['name'], d, 'nothing' if j is None else
                    '%s ripeness %.3f' % (gts[j]['id'], gts[j]['ripeness'])))
        for j, g in enumerate(gts):
            if care[j] and g['ripeness'] >= RIPE:
                i = next((i for i, jj in pairs.items() if jj == j), None)
                if i is None or dets[i].score < args.min_ripeness:
                    fn += 1
                    fn_log.append('%s gt %s ripeness %.3f visible %.2f %s' % (
                        frame['name'], g['id'], g['ripeness'], g['visible'],
                        'undetected' if i is None else 'graded %.3f' % dets[i].score))
    precision = tp / float(tp + fp) if tp + fp else 1.0
    recall = tp / float(tp + fn) if tp + fn else 1.0
    f1 = 2 * precision * recall / (precision + recall) if precision + recall else 0.0

    def pct(values, q):
        return float(np.percentile(values, q)) if values else float('nan')

    log('frames: %d (%dx%d), detector %s' % (frames, 1024, 768, detector.params))
    log('ripe-fruit detection (score >= %.2f, IoU >= %.1f, visible >= %.2f): TP %d FP %d FN %d'
        ' (%d ripe detections on mostly hidden fruit ignored)'
        % (args.min_ripeness, IOU_MIN, args.min_visible, tp, fp, fn, ignored))
    log('  precision %.3f  recall %.3f  F1 %.3f' % (precision, recall, f1))
    log('stage accuracy: %.3f (%d/%d matched fruit)' % (
        stage_ok / float(stage_total) if stage_total else float('nan'), stage_ok, stage_total))
    log('  confusion (rows truth, cols detected: %s):' % ', '.join(STAGE_NAMES))
    for k, row in enumerate(confusion):
        log('    %-8s %s' % (STAGE_NAMES[k], ' '.join('%4d' % v for v in row)))
    log('3D pick-point error [mm] (ripe TP, %d without a 3D point): all n=%d median %.1f p95 %.1f;'
        ' depth 0.4-0.8 m n=%d median %.1f p95 %.1f' % (
            no_point, len(err_all), 1000 * pct(err_all, 50), 1000 * pct(err_all, 95),
            len(err_range), 1000 * pct(err_range, 50), 1000 * pct(err_range, 95)))
    log('CPU time per 1024x768 frame, one core [ms]: detection median %.1f p95 %.1f mean %.1f; '
        'localisation per fruit median %.2f; offline StereoBM median %.0f' % (
            pct(det_ms, 50), pct(det_ms, 95), float(np.mean(det_ms)) if det_ms else float('nan'),
            pct(loc_ms, 50), pct(bm_ms, 50)))
    if args.verbose:
        for line in fp_log:
            log('FP ' + line)
        for line in fn_log:
            log('FN ' + line)
    return dict(precision=precision, recall=recall, f1=f1, tp=tp, fp=fp, fn=fn,
                stage_accuracy=stage_ok / float(stage_total) if stage_total else float('nan'),
                err_median=pct(err_all, 50), err_p95=pct(err_all, 95),
                err_range_median=pct(err_range, 50), det_ms_median=pct(det_ms, 50))


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--frames', type=int, default=200)
    parser.add_argument('--seed', type=int, default=1)
    parser.add_argument('--cache-dir', default='/tmp/vision_bench_frames')
    parser.add_argument('--min-ripeness', type=float, default=RIPE)
    parser.add_argument('--min-visible', type=float, default=0.5)
    parser.add_argument('--config', default=None, help='image_processing.yaml (detector)')
    parser.add_argument('--stereo-config', default=None, help='stereo_image_proc.yaml')
    parser.add_argument('-v', '--verbose', action='store_true', help='list every FP and FN')
    args = parser.parse_args(argv)
    run(args)
    return 0
