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
With --photo-variants the photos are run again under photometric variants of themselves
(bench_photos.PHOTO_VARIANTS: white balance casts, exposure, gamma, JPEG, blur), a line of
ripe-fruit figures each, then their mean and lowest ripe F1: seven photos are few, and a change
that holds across the variants is less likely tuned to their pixels than to the fruit. With
--photo-widths W,W,... the same for the photos scaled to each width (the fruit's size in pixels
changes as with another camera's field of view or distance; "care" from the detector's
min_radius_px at that width).

This module runs the two benchmarks and holds the command line; its parts (re-exported here):
bench_frames (knob sweep, render cache, ground truth), bench_metrics (IoU, matching,
Evaluation), bench_photos (label loader, photo folder), bench_config (detector and StereoBM
parameters).
"""
import argparse
import glob
import os
import time

import cv2
import numpy as np

from vision_pkg import localisation
from vision_pkg.bench_config import _package_dir, load_detector, load_stereo_params  # noqa: F401
from vision_pkg.bench_frames import SWEEP, render_frames, silhouette_box  # noqa: F401
from vision_pkg.bench_metrics import (IOU_MIN, RIPE, Evaluation, _pct, _ratio, clip_box,  # noqa: F401
                                      iou, match)
from vision_pkg.bench_photos import (PHOTO_VARIANTS, STAGE_BY_NAME, LabelError,  # noqa: F401
                                     default_photo_dir, load_labels, photo_variant)
from vision_pkg.detection import STAGE_NAMES, STAGE_RED, TomatoDetector, stage_of  # noqa: F401


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
        p_right = [frame['fx'], 0.0, frame['cx'], -frame['fx'] * frame['baseline'],
                   0.0, frame['fy'], frame['cy'], 0.0, 0.0, 0.0, 1.0, 0.0]
        cloud = locs = None
        if dets:
            t0 = time.perf_counter()
            cloud = localisation.offline_cloud(left, right, stereo, frame['fx'], frame['fy'],
                                               frame['cx'], frame['cy'], frame['baseline'])
            bm_ms.append((time.perf_counter() - t0) * 1000.0)
            # every detection, as the node does: their order in depth (locate_all), and the
            # grade of a fruit whose part is mostly something in front of it (regrade)
            t0 = time.perf_counter()
            locs = localisation.locate_all(cloud, dets, p_right, image=right)
            loc_ms.append((time.perf_counter() - t0) * 1000.0 / len(dets))
            dets = [d for d, _ in localisation.regrade(detector, cloud, list(zip(dets, locs)),
                                                       p_right, right)]
        gts = [dict(box=clip_box(g['box'], w, h), stage=stage_of(g['ripeness']), id=g['id'],
                    care=g['visible'] >= args.min_visible) for g in frame['fruits']]
        pairs = ev.add(frame['name'], dets, _det_boxes(dets, w, h), gts, ms)
        if args.annotate_render and len(frame['fruits']) >= 5 and \
                not os.path.exists(args.annotate_render):
            from vision_pkg.annotate import annotate
            cv2.imwrite(args.annotate_render, annotate(right, [(d, -1) for d in dets]))
            log('annotated render %s written to %s' % (frame['name'], args.annotate_render))
        for i, d in enumerate(dets):
            j = pairs.get(i)
            if j is None or not gts[j]['care'] or d.score < args.min_ripeness or \
                    frame['fruits'][j]['ripeness'] < RIPE:
                continue
            loc = locs[i]
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
    log('localisation per detection (locate_all of a frame over its detections) median %.2f ms;'
        ' offline StereoBM median %.0f ms' % (
        _pct(loc_ms, 50), _pct(bm_ms, 50)))
    figures.update(err_median=_pct(err_all, 50), err_p95=_pct(err_all, 95),
                   err_range_median=_pct(err_range, 50))
    return figures


# ------------------------------------------------------------------------------ real photos
def _photo_truth(labels, scale, width, height, detector, min_visible, min_radius=None):
    """Ground truth of one photo scaled by `scale` (Evaluation.add's gts). A fruit smaller
    than `min_radius` (px of the scaled photo; None: the detector's min_radius_px there) is
    "don't care"."""
    if min_radius is None:
        min_radius = detector.min_radius_input(width)
    gts = []
    for f in labels:
        u, v, r = f['u'] * scale, f['v'] * scale, f['r'] * scale
        gts.append(dict(box=clip_box([u - r, v - r, u + r, v + r], width, height),
                        stage=f['stage'], id=f['id'], care=f['visible'] >= min_visible and
                        r >= min_radius))
    return gts


def run_photos(args, log=print):
    """Labelled real photos: detection and grading figures, or None when there are none.
    With args.photo_variants, also the ripe-fruit figures of every photometric variant
    (bench_photos.PHOTO_VARIANTS), in figures['variants'] as {name: figures}."""
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
    photos = []          # (name, scaled image, ground truth)
    widths = getattr(args, 'photo_widths', None)
    originals = []       # (name, image as read, labels): kept only for --photo-widths
    for name in sorted(labels):
        image = cv2.imread(os.path.join(photo_dir, name))
        if image is None:
            missing.append(name)
            continue
        if widths:
            originals.append((name, image, labels[name]))
        s = args.photo_width / float(image.shape[1])
        image = cv2.resize(image, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        h, w = image.shape[:2]
        gts = _photo_truth(labels[name], s, w, h, detector, args.min_visible,
                           getattr(args, 'min_care_radius', None))
        photos.append((name, image, gts))
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
    figures = ev.report(log, args.verbose, args.min_visible)
    if getattr(args, 'photo_variants', False) and photos:
        figures['variants'] = run_photo_variants(detector, photos, args.min_ripeness, log,
                                                 args.verbose)
    if originals:
        figures['widths'] = run_photo_widths(detector, originals, widths, args.min_ripeness,
                                             args.min_visible, log, args.verbose)
    return figures


def run_photo_widths(detector, originals, widths, min_ripeness, min_visible, log=print,
                     verbose=False):
    """Ripe-fruit figures of the photos scaled to each of `widths` (pixels wide, at most the
    detector's reference width: a wider image is seen at that width anyway): the same scenes
    with every fruit smaller or larger in pixels, as another camera's field of view or
    distance would show them. A labelled fruit is "care" when its radius at that width is at
    least the detector's min_radius_px. A line per width, then the mean and the lowest ripe
    F1. originals: [(name, BGR image as read, its labels)]. Returns {width: figures}."""
    log('== real photos at other widths (fruit sizes in pixels; ripe fruit; stage accuracy '
        'of the fruit found):')

    def scaled_photos(width):
        for name, image, labels in originals:
            s = width / float(image.shape[1])
            scaled = cv2.resize(image, None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
            h, w = scaled.shape[:2]
            yield name, scaled, _photo_truth(labels, s, w, h, detector, min_visible)
    return _sweep(detector, [('%5d px wide' % width, width, width) for width in widths],
                  scaled_photos, min_ripeness, 'widths', log, verbose)


def _widths(text):
    """--photo-widths: comma-separated positive integers."""
    try:
        widths = [int(w) for w in text.split(',') if w.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError('comma-separated widths in pixels, not %r' % text)
    if not widths or any(w < 64 for w in widths):
        raise argparse.ArgumentTypeError('widths of at least 64 px, not %r' % text)
    return widths


def run_photo_variants(detector, photos, min_ripeness, log=print, verbose=False):
    """Ripe-fruit figures of the photos under every photometric variant of PHOTO_VARIANTS
    (one detection per photo, no timing): a line per variant, then the mean and the lowest
    ripe F1. photos: [(name, scaled BGR image, ground truth)]. Returns {name: figures}."""
    log('== real photos under photometric variants (ripe fruit; stage accuracy of the fruit '
        'found):')

    def varied_photos(variant):
        kind, value = variant
        for photo, image, gts in photos:
            yield photo, photo_variant(image, kind, value), gts
    return _sweep(detector, [(name, name, variant) for name, variant in PHOTO_VARIANTS],
                  varied_photos, min_ripeness, 'variants', log, verbose)


def _sweep(detector, settings, photos, min_ripeness, what, log, verbose):
    """The photos under each setting: settings [(label, key, arg)], photos(arg) yields (name,
    image, ground truth) of each photo under it; one detection per photo (no timing); a line of
    ripe-fruit figures per setting, then the mean and the lowest ripe F1 over them. Returns
    {key: figures}."""
    out, labels = {}, {}
    for label, key, arg in settings:
        ev = Evaluation(min_ripeness)
        for name, image, gts in photos(arg):
            dets = detector.detect(image)
            ev.add(name, dets, _det_boxes(dets, image.shape[1], image.shape[0]), gts, 0.0)
        fig = ev.figures()
        out[key], labels[key] = fig, label
        log('  %-16s ripe F1 %.3f (P %.3f R %.3f; TP %d FP %d FN %d), stage accuracy %.3f' % (
            label, fig['f1'], fig['precision'], fig['recall'], fig['tp'], fig['fp'], fig['fn'],
            fig['stage_accuracy']))
        if verbose:
            for line in ev.fp_log:
                log('    FP %s' % line)
            for line in ev.fn_log:
                log('    FN %s' % line)
    f1 = [fig['f1'] for fig in out.values()]
    worst = min(out, key=lambda k: out[k]['f1'])
    log('  ripe F1 over the %d %s: mean %.3f, lowest %.3f (%s)' % (
        len(f1), what, float(np.mean(f1)), out[worst]['f1'], labels[worst].strip()))
    return out


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
    parser.add_argument('--photo-variants', action='store_true',
                        help='also run the photos under photometric variants (white balance '
                             'casts, exposure, gamma, JPEG, blur) and print their ripe F1')
    parser.add_argument('--photo-widths', type=_widths, default=None, metavar='W,W,...',
                        help='also run the photos scaled to these widths (fruit smaller or '
                             'larger in pixels, e.g. 640,768,896,1024) and print their ripe F1')
    parser.add_argument('--min-care-radius', type=float, default=None, metavar='PX',
                        help='photos: a labelled fruit of a smaller radius (px at --photo-width)'
                             ' is "don\'t care" (default: the detector\'s min_radius_px)')
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
