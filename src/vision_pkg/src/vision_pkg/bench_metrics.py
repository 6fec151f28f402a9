"""The detection benchmark's figures, rospy-free: box IoU, greedy one-to-one matching of detections
to ground-truth fruit, and the Evaluation that counts ripe-fruit TP/FP/FN, the stage confusion and
per-stage detections over frames and reports them. Definitions in vision_pkg.bench's docstring.
"""
import numpy as np

from vision_pkg.detection import STAGE_NAMES, STAGE_RED

RIPE = 0.7
IOU_MIN = 0.5


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
