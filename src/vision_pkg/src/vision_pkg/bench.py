"""Benchmark of the tomato detector, grader and 3D localisation (no ROS): on harvest_sim renders
and on a folder of labelled real photographs.

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

Real photographs (--photos DIR, labels --labels YAML, default: the development photos in
../shared/data/real-tomato-photos beside the workspace and their hand labels in
vision_pkg/data/real_tomato_photos.yaml): every photo is scaled to 1024 pixels wide, as a
camera frame would be; a labelled fruit (circle u, v, r and a stage) is "care" when its
visible fraction is >= --min-visible and its radius at 1024 wide >= the detector's
min_radius_px, otherwise "don't care" as above. Ripe = stage red. The same figures as on
renders (no 3D), plus detection precision and recall per stage (a detection graded s that
matches a care fruit of stage s is a true positive of s) and over all stages (any fruit).
"""
import argparse
import glob
import json
import math
import os
import time

import cv2
import numpy as np
import yaml

from vision_pkg import localisation
from vision_pkg.detection import STAGE_NAMES, STAGE_RED, TomatoDetector, stage_of

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


def _pct(values, q):
    return float(np.percentile(values, q)) if len(values) else float('nan')


class Evaluation(object):
    """Detection and grading figures accumulated over frames (renders or labelled photos).

    Per frame: the detections, the ground-truth fruit (box, stage, care) and the detection's
    CPU time. See the module docstring for the definitions."""

    def __init__(self, min_ripeness=RIPE):
        self.min_ripeness = min_ripeness
        self.tp = self.fp = self.fn = self.ignored = 0
        self.confusion = np.zeros((4, 4), dtype=int)
        self.stage_tp = np.zeros(4, dtype=int)      # graded s, matched to a care fruit of s
        self.stage_det = np.zeros(4, dtype=int)     # graded s, not on a don't-care fruit
        self.stage_gt = np.zeros(4, dtype=int)      # care fruit of stage s
        self.any_tp = self.any_det = self.any_gt = 0
        self.det_ms = []
        self.frames = 0
        self.fp_log, self.fn_log = [], []

    def add(self, name, dets, det_boxes, gts, ms):
        """gts: list of dict(box, stage, care, id); returns {det index: gt index} of matches."""
        self.frames += 1
        self.det_ms.append(ms)
        gt_boxes = [g['box'] for g in gts]
        pairs = dict(match(det_boxes, gt_boxes))
        for g in gts:
            if g['care']:
                self.stage_gt[g['stage']] += 1
                self.any_gt += 1
        for i, d in enumerate(dets):
            j = pairs.get(i)
            if j is not None and not gts[j]['care']:
                continue
            on_dont_care = j is None and any(
                not g['care'] and g['box'][0] <= d.u <= g['box'][2] and
                g['box'][1] <= d.v <= g['box'][3] for g in gts)
            if j is not None:
                true_stage = gts[j]['stage']
                self.confusion[true_stage, d.stage] += 1
                self.stage_tp[d.stage] += int(true_stage == d.stage)
                self.any_tp += 1
            if not on_dont_care:
                self.stage_det[d.stage] += 1
                self.any_det += 1
            if d.score < self.min_ripeness:
                continue
            if on_dont_care:
                self.ignored += 1        # on a mostly hidden or tiny fruit: neither TP nor FP
            elif j is not None and gts[j]['stage'] == STAGE_RED:
                self.tp += 1
            else:
                self.fp += 1
                self.fp_log.append('%s det %r matched %s' % (
                    name, d, 'nothing' if j is None else
                    '%s (%s)' % (gts[j]['id'], STAGE_NAMES[gts[j]['stage']])))
        for j, g in enumerate(gts):
            if g['care'] and g['stage'] == STAGE_RED:
                i = next((i for i, jj in pairs.items() if jj == j), None)
                if i is None or dets[i].score < self.min_ripeness:
                    self.fn += 1
                    self.fn_log.append('%s gt %s %s' % (
                        name, g['id'], 'undetected' if i is None else
                        'graded %.3f' % dets[i].score))
        return pairs

    def figures(self):
        precision = self.tp / float(self.tp + self.fp) if self.tp + self.fp else 1.0
        recall = self.tp / float(self.tp + self.fn) if self.tp + self.fn else 1.0
        f1 = 2 * precision * recall / (precision + recall) if precision + recall else 0.0
        matched = int(self.confusion.sum())
        return dict(precision=precision, recall=recall, f1=f1, tp=self.tp, fp=self.fp,
                    fn=self.fn, stage_accuracy=float(np.trace(self.confusion)) / matched
                    if matched else float('nan'),
                    det_ms_median=_pct(self.det_ms, 50), det_ms_p95=_pct(self.det_ms, 95),
                    frames=self.frames)

    def report(self, log, verbose=False, min_visible=0.5):
        f = self.figures()
        log('ripe-fruit detection (score >= %.2f, IoU >= %.1f, visible >= %.2f): TP %d FP %d '
            'FN %d (%d ripe detections on don\'t-care fruit ignored)'
            % (self.min_ripeness, IOU_MIN, min_visible, self.tp, self.fp, self.fn,
               self.ignored))
        log('  precision %.3f  recall %.3f  F1 %.3f' % (f['precision'], f['recall'], f['f1']))
        matched = int(self.confusion.sum())
        log('stage accuracy: %.3f (%d/%d matched fruit)' % (
            f['stage_accuracy'], int(np.trace(self.confusion)), matched))
        log('  confusion (rows truth, cols detected: %s):' % ', '.join(STAGE_NAMES))
        for k, row in enumerate(self.confusion):
            log('    %-8s %s' % (STAGE_NAMES[k], ' '.join('%4d' % v for v in row)))
        log('detection per stage (graded stage = true stage), precision / recall:')
        for k in range(4):
            log('    %-8s P %s (%d detections)  R %s (%d fruit)' % (
                STAGE_NAMES[k], _ratio(self.stage_tp[k], self.stage_det[k]), self.stage_det[k],
                _ratio(self.stage_tp[k], self.stage_gt[k]), self.stage_gt[k]))
        log('    %-8s P %s (%d detections)  R %s (%d fruit)' % (
            'any', _ratio(self.any_tp, self.any_det), self.any_det,
            _ratio(self.any_tp, self.any_gt), self.any_gt))
        log('CPU time per frame, one core [ms]: detection median %.1f p95 %.1f mean %.1f' % (
            f['det_ms_median'], f['det_ms_p95'],
            float(np.mean(self.det_ms)) if self.det_ms else float('nan')))
        if verbose:
            for line in self.fp_log:
                log('FP ' + line)
            for line in self.fn_log:
                log('FN ' + line)
        return f


def _ratio(a, b):
    return '%.3f' % (a / float(b)) if b else '  -  '


def _timed_detect(detector, image):
    t0 = time.process_time()          # CPU time of this (single-threaded) process
    dets = detector.detect(image)
    return dets, (time.process_time() - t0) * 1000.0


def _det_boxes(dets, w, h):
    boxes = []
    for d in dets:
        x, y, bw, bh = d.box(w, h)
        boxes.append([x, y, x + bw - 1.0, y + bh - 1.0])
    return boxes


def run(args, log=print):
    """Renders: detection, grading and 3D error. Returns the figures."""
    cv2.setNumThreads(1)
    detector = load_detector(args.config)
    stereo = load_stereo_params(args.stereo_config)
    ev = Evaluation(args.min_ripeness)
    err_all, err_range = [], []
    no_point = 0
    loc_ms, bm_ms = [], []
    detector.detect(np.zeros((768, 1024, 3), np.uint8))     # warm-up outside the timing
    for frame in render_frames(args.frames, args.cache_dir, args.seed, log):
        right, left = frame['right'], frame['left']
        h, w = right.shape[:2]
        dets, ms = _timed_detect(detector, right)
        gts = [dict(box=clip_box(g['box'], w, h), stage=stage_of(g['ripeness']), id=g['id'],
                    care=g['visible'] >= args.min_visible) for g in frame['fruits']]
        pairs = ev.add(frame['name'], dets, _det_boxes(dets, w, h), gts, ms)
        if args.annotate_render and len(frame['fruits']) >= 5 and \
                not os.path.exists(args.annotate_render):
            from vision_pkg.annotate import annotate
            cv2.imwrite(args.annotate_render, annotate(right, [(d, -1) for d in dets]))
            log('annotated render %s written to %s' % (frame['name'], args.annotate_render))
        cloud = None
        p_right = [frame['fx'], 0.0, frame['cx'], -frame['fx'] * frame['baseline'],
                   0.0, frame['fy'], frame['cy'], 0.0, 0.0, 0.0, 1.0, 0.0]
        for i, d in enumerate(dets):
            j = pairs.get(i)
            if j is None or not gts[j]['care'] or d.score < args.min_ripeness or \
                    frame['fruits'][j]['ripeness'] < RIPE:
                continue
            if cloud is None:
                t0 = time.perf_counter()
                cloud = localisation.offline_cloud(left, right, stereo, frame['fx'],
                                                   frame['fy'], frame['cx'], frame['cy'],
                                                   frame['baseline'])
                bm_ms.append((time.perf_counter() - t0) * 1000.0)
            t0 = time.perf_counter()
            loc = localisation.locate(cloud, d, p_right, image=right)
            loc_ms.append((time.perf_counter() - t0) * 1000.0)
            if loc is None:
                no_point += 1
                continue
            truth = np.array(frame['fruits'][j]['centre_left'])
            err = float(np.linalg.norm(loc.centre - truth))
            err_all.append(err)
            if 0.4 <= truth[2] <= 0.8:
                err_range.append(err)
    log('== renders: %d frames (1024x768), detector %s' % (ev.frames, detector.params))
    figures = ev.report(log, args.verbose, args.min_visible)
    log('3D pick-point error [mm] (ripe TP, %d without a 3D point): all n=%d median %.1f p95 %.1f;'
        ' depth 0.4-0.8 m n=%d median %.1f p95 %.1f' % (
            no_point, len(err_all), 1000 * _pct(err_all, 50), 1000 * _pct(err_all, 95),
            len(err_range), 1000 * _pct(err_range, 50), 1000 * _pct(err_range, 95)))
    log('localisation per fruit median %.2f ms; offline StereoBM median %.0f ms' % (
        _pct(loc_ms, 50), _pct(bm_ms, 50)))
    figures.update(err_median=_pct(err_all, 50), err_p95=_pct(err_all, 95),
                   err_range_median=_pct(err_range, 50))
    return figures


# ------------------------------------------------------------------------------ real photos
STAGE_BY_NAME = {name: k for k, name in enumerate(STAGE_NAMES)}


class LabelError(ValueError):
    """A malformed label file: `FILE: field.path: problem`."""


def load_labels(path):
    """{photo file name: [dict(u, v, r, stage (index), visible)]} of a label YAML."""
    try:
        with open(path) as handle:
            data = yaml.load(handle, Loader=yaml.SafeLoader)
    except (OSError, yaml.YAMLError) as exc:
        raise LabelError('%s: %s' % (path, exc))
    if not isinstance(data, dict) or not isinstance(data.get('photos'), dict):
        raise LabelError('%s: photos: missing or not a mapping' % path)
    out = {}
    for name, photo in data['photos'].items():
        fruits = (photo or {}).get('fruits') if isinstance(photo, dict) else None
        if not isinstance(fruits, list):
            raise LabelError('%s: photos.%s.fruits: missing or not a list' % (path, name))
        items = []
        for k, fruit in enumerate(fruits):
            where = '%s: photos.%s.fruits[%d]' % (path, name, k)
            if not isinstance(fruit, dict):
                raise LabelError('%s: not a mapping' % where)
            try:
                u, v, r = (float(fruit[key]) for key in ('u', 'v', 'r'))
                visible = float(fruit.get('visible', 1.0))
            except (KeyError, TypeError, ValueError) as exc:
                raise LabelError('%s: u, v, r (numbers) and visible: %s' % (where, exc))
            if not all(math.isfinite(x) for x in (u, v, r, visible)) or r <= 0 or \
                    not 0.0 <= visible <= 1.0:
                raise LabelError('%s: u, v finite, r > 0, 0 <= visible <= 1' % where)
            stage = STAGE_BY_NAME.get(fruit.get('stage'))
            if stage is None:
                raise LabelError('%s.stage: %r is not one of %s' % (
                    where, fruit.get('stage'), ', '.join(STAGE_NAMES)))
            items.append(dict(u=u, v=v, r=r, stage=stage, visible=visible,
                              id='%s#%d' % (name, k)))
        out[str(name)] = items
    return out


def default_photo_dir():
    """../shared/data/real-tomato-photos beside the workspace (None when absent)."""
    workspace = os.path.abspath(os.path.join(_package_dir(), '..', '..'))
    path = os.path.join(os.path.dirname(workspace), 'shared', 'data', 'real-tomato-photos')
    return path if os.path.isdir(path) else None


def run_photos(args, log=print):
    """Labelled real photos: detection and grading figures, or None when there are none."""
    photo_dir = args.photos or default_photo_dir()
    labels_path = args.labels or os.path.join(_package_dir(), 'data', 'real_tomato_photos.yaml')
    if not photo_dir or not os.path.isdir(photo_dir):
        log('== real photos: no photo folder (%s); skipped' % (
            photo_dir or '../shared/data/real-tomato-photos not found beside the workspace'))
        return None
    labels = load_labels(labels_path)
    cv2.setNumThreads(1)
    detector = load_detector(args.config)
    detector.detect(np.zeros((768, 1024, 3), np.uint8))
    ev = Evaluation(args.min_ripeness)
    missing = []
    for name in sorted(labels):
        image = cv2.imread(os.path.join(photo_dir, name))
        if image is None:
            missing.append(name)
            continue
        s = args.photo_width / float(image.shape[1])
        image = cv2.resize(image, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        h, w = image.shape[:2]
        gts = []
        for f in labels[name]:
            u, v, r = f['u'] * s, f['v'] * s, f['r'] * s
            gts.append(dict(box=clip_box([u - r, v - r, u + r, v + r], w, h), stage=f['stage'],
                            id=f['id'], care=f['visible'] >= args.min_visible and
                            r >= detector.params['min_radius_px']))
        times = []
        for _ in range(args.repeat):
            dets, ms = _timed_detect(detector, image)
            times.append(ms)
        ev.add(name, dets, _det_boxes(dets, w, h), gts, float(np.median(times)))
        if args.save_dir:
            from vision_pkg.annotate import annotate
            os.makedirs(args.save_dir, exist_ok=True)
            out = annotate(image, [(d, -1) for d in dets])
            for g in gts:
                x0, y0, x1, y1 = [int(round(c)) for c in g['box']]
                cv2.rectangle(out, (x0, y0), (x1, y1), (255, 255, 255) if g['care']
                              else (128, 128, 128), 1)
            cv2.imwrite(os.path.join(args.save_dir, os.path.splitext(name)[0] + '.png'), out)
    others = sorted(set(os.path.basename(p) for p in glob.glob(os.path.join(photo_dir, '*.jpg')))
                    - set(labels))
    log('== real photos: %d labelled photos in %s scaled to %d wide%s%s' % (
        ev.frames, photo_dir, args.photo_width,
        '; missing: %s' % ', '.join(missing) if missing else '',
        '; unlabelled (not used): %s' % ', '.join(others) if others else ''))
    return ev.report(log, args.verbose, args.min_visible)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--frames', type=int, default=200, help='rendered frames (0: none)')
    parser.add_argument('--seed', type=int, default=1)
    parser.add_argument('--cache-dir', default='/tmp/vision_bench_frames')
    parser.add_argument('--min-ripeness', type=float, default=RIPE)
    parser.add_argument('--min-visible', type=float, default=0.5)
    parser.add_argument('--config', default=None, help='image_processing.yaml (detector)')
    parser.add_argument('--stereo-config', default=None, help='stereo_image_proc.yaml')
    parser.add_argument('--photos', default=None,
                        help='folder of labelled photos (default ../shared/data/real-tomato-photos'
                             ' beside the workspace; skipped when absent)')
    parser.add_argument('--labels', default=None,
                        help='label YAML (default vision_pkg/data/real_tomato_photos.yaml)')
    parser.add_argument('--photo-width', type=int, default=1024,
                        help='photos are scaled to this width first')
    parser.add_argument('--repeat', type=int, default=3,
                        help='detections per photo; the median CPU time counts')
    parser.add_argument('--save-dir', default=None,
                        help='write annotated photos here (outside the repository: the '
                             'development photos are licensed non-commercial)')
    parser.add_argument('--annotate-render', default=None, metavar='PNG',
                        help='write the detections on the first render with >= 5 fruit here '
                             '(when the file does not exist yet)')
    parser.add_argument('-v', '--verbose', action='store_true', help='list every FP and FN')
    args = parser.parse_args(argv)
    if args.frames > 0:
        run(args)
    try:
        run_photos(args)
    except LabelError as exc:
        print('bench_detection: %s' % exc)
        return 1
    return 0
