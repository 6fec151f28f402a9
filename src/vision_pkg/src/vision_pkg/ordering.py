"""Picking order of the pickable tomatoes (section 3.5.1.2): bottom to top, then left to right.

Works in image coordinates of the right rectified image (u to the right, v downwards), so
"bottom" is the largest v. Fruit whose v differ by at most the row tolerance from the lowest
fruit of the current row belong to that row; a row is picked left to right (increasing u).
Anchoring each row at its lowest fruit keeps a chain of slightly staggered fruit from growing
one endless row.
"""


def picking_order(points, row_tolerance):
    """Indices of `points` [(u, v), ...] in picking order.

    row_tolerance: largest v difference [px] to the lowest fruit of a row for the same row.
    Ties are broken by the original index, so the order is deterministic.
    """
    if row_tolerance < 0:
        raise ValueError('row_tolerance must be >= 0')
    by_height = sorted(range(len(points)), key=lambda i: (-points[i][1], points[i][0], i))
    rows = []
    for i in by_height:
        if rows and rows[-1][0] - points[i][1] <= row_tolerance:
            rows[-1][1].append(i)
        else:
            rows.append((points[i][1], [i]))
    order = []
    for _, members in rows:
        order.extend(sorted(members, key=lambda i: (points[i][0], i)))
    return order


def inside_image(u, v, radius_px, width, height, margin_px=0.0):
    """True when the circle (u, v, radius_px) lies inside the image with `margin_px` to spare."""
    return (u - radius_px >= margin_px and v - radius_px >= margin_px and
            u + radius_px <= width - 1 - margin_px and v + radius_px <= height - 1 - margin_px)


def servo_target(centres, radii, ref, on_fruit=True):
    """Index of the fruit the visual servo follows, or None: the detection (centre (u, v),
    radius [px]) nearest to `ref`, the projection of the target's expected centre. With
    `on_fruit`, only a fruit whose circle holds that projection qualifies: the held fruit's
    centre projects onto its own silhouette, while a neighbour merely nearest to it (the held
    fruit not seen in this frame) would lead the shear beside the pedicel."""
    best, best_d = None, None
    for i, ((u, v), r) in enumerate(zip(centres, radii)):
        d = ((u - ref[0]) ** 2 + (v - ref[1]) ** 2) ** 0.5
        if on_fruit and d > r:
            continue
        if best is None or d < best_d:
            best, best_d = i, d
    return best
