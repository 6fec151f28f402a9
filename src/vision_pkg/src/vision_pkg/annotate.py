"""Drawing of detections on the right rectified image (as in the paper's Figure 15), rospy-free."""
import cv2

from vision_pkg.detection import STAGE_NAMES

#: BGR colour per ripeness stage (green, turning, pink, red)
STAGE_BGR = ((40, 200, 40), (0, 200, 230), (180, 120, 255), (0, 0, 230))
#: RGB 0..1 colour per stage, for markers
STAGE_RGB = tuple((b / 255.0, g / 255.0, r / 255.0) for (b, g, r) in STAGE_BGR)


def annotate(image, items):
    """Return a copy of a BGR image with one box and label per item.

    items: iterable of (detection, pick_order) with pick_order -1 for non-pickable fruit.
    Pickable fruit get a thick box and their 1-based order; others a thin box.
    """
    out = image.copy()
    h, w = out.shape[:2]
    for det, order in items:
        x, y, bw, bh = det.box(w, h)
        colour = STAGE_BGR[det.stage]
        thick = 3 if order >= 0 else 1
        cv2.rectangle(out, (x, y), (x + bw - 1, y + bh - 1), colour, thick)
        label = '%s %.2f' % (STAGE_NAMES[det.stage], det.score)
        if order >= 0:
            label = '#%d %s' % (order + 1, label)
        ty = y - 6 if y > 18 else y + bh + 16
        cv2.putText(out, label, (x, ty), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 3,
                    cv2.LINE_AA)
        cv2.putText(out, label, (x, ty), cv2.FONT_HERSHEY_SIMPLEX, 0.5, colour, 1, cv2.LINE_AA)
    return out
