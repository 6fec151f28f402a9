"""3D picking point of a detected tomato from an organized stereo point cloud, rospy-free.

The cloud is what stereo_image_proc publishes on stereo/points2: organized on the LEFT
rectified image grid, points in the LEFT optical frame, NaN where the disparity is invalid.
Detections live in the RIGHT rectified image, so every cloud point is mapped into the right
image through the right camera's projection matrix P (Tx = -fx * baseline) and kept when it
falls on the fruit's visible part.

The fruit is a sphere of unknown radius R whose silhouette in the right image is an ellipse
(a circle on the optical axis): the rays tangent to a sphere form a right circular cone round
the ray to its centre, so every ray through the silhouette's outline makes the same angle alpha
with that centre ray (sin alpha = R / D, D the centre distance). The part's outline pixels
that follow the detector's circle (within OUTLINE_TOL of it: where the fruit's own edge is
seen, not an occluder's) give that cone by linear least squares (`silhouette_cone`: m . w = 1
for their unit rays m, w = c / cos alpha). Until the twenty-first session the circle alone
gave it (`sphere_ray`, which reads the circle as the least-squares circle of the whole
ellipse): right for a whole silhouette, but a fruit cut by the image's border shows only part
of its ellipse, whose circle is not that (plant_factory_led f02_3, held in the image's corner:
3D radius 52.6 mm for 44.6, moved 14 mm by the relocation, the shear closed 12 mm from its
peduncle and the fruit was torn off), and the circle's misfit to the ellipse's ends costs
even whole silhouettes: renders 3D error median 0.8 / 0.9 / 0.8 -> 0.6 / 0.7 / 0.6 mm, p95
4.8 / 5.1 / 5.0 -> 3.8 / 4.9 / 4.5 mm on seeds 1-3. Without a part mask, with fewer than
MIN_POINTS such pixels or with a cone the circle contradicts (`_cone_agrees`: an outline on a
short arc of the circle constrains the cone poorly) the circle's sphere_ray is used. Each
surface point p on the fruit gives its own centre-distance estimate: its depth t along the
centre ray pushed back by the sphere's thickness at its lateral offset rho,
D_i = t + sqrt(R^2 - rho^2) (for the central point, exactly "the surface point pushed back by
the radius along the viewing ray"). The median of the D_i over valid points (holes and
outliers do not matter), iterated twice with R = D sin alpha, gives the centre; only points
with rho < EDGE_FRACTION * R are used, because block matching smears the disparity of the
fruit rim onto the background and back.

Glossy skin: the highlight of a light source in the skin is the source's virtual image in a
convex mirror, behind the skin (the focal length R/2 behind its mirror point, seen head-on, light
far away). Each eye sees it at a different point of the skin, so block matching ranges that
virtual image, not the skin. Where the skin has texture of its own it outvotes the highlight;
in dim light it has none, the highlight and its sheen are all that match, and the fruit came out
12-15 mm too far (renders with one warm lamp at 40 % intensity: 3D error median 12.4 mm). Given
the image the detection was made on, a point whose pixel is at least SPECULAR_RATIO times as
bright (HSV value) as the median of the fruit's visible part is ranged as that virtual image:
D_i = t + k R (`virtual_image_factor`). Seen head-on (a highlight at the disc centre) k = 1/2.
Off-centre the mirror point's normal is at an angle theta from the view ray (sin theta = the
pixel's offset from the circle's centre over its radius) and the reflected pencil is
astigmatic (Coddington: focal length f cos theta in the plane of incidence, whose image is the
line through the disc centre, f / cos theta across it, f = R/2); a horizontal baseline ranges
the horizontal vergence cos^2 phi / f_t + sin^2 phi / f_s (phi between the image rows and that
line), and the mirror point itself is R cos theta in front of the centre. A light from above
mirrored at the top of the fruit at 45 degrees is thus ranged at the centre's own depth (k = 0),
where R/2 put the fruit 15-17 mm too far (a low_light mission's cut missed by 15 mm). The angle
is capped at SPECULAR_MAX_SIN (the rim's points are block matching's least sure).
Block matching does not range a highlight pixel at the virtual image itself: its window holds
the skin's texture around the highlight too, and the broad sheen is a smooth lobe that weighs
less than that texture. On the renders the dim sheen of the sky above a fruit was ranged 10-12
mm behind the skin where the virtual image lies about twice as deep (low_light f00_2), and
with the whole mirror shift that fruit came out 10-16 mm too near. So a highlight pixel is
ranged VIRTUAL_IMAGE_SHARE (3/4) of the way from the skin to the virtual image
(`highlight_factor`). low_light's ripe fruit at its three picking points, each in the four
noise frames of the live cameras: depth error median 3.2 -> 1.7 mm, p95 12.6 -> 10.0 mm, the
largest 20 -> 15 mm (in the benchmark's four noise frames p95 13.6 -> 7.3 mm); renders seed 2
3D p95 8.9 -> 7.6 mm, seed 1 5.8 -> 5.9; the bright scenarios unchanged (their highlight
points are few and outvoted). With half the shift the renders' dim frames' median error grew
from 3.3 to 5.4 mm. A low_light mission still loses one fruit of eight: f00_2, 13 mm too near
before, is now cut (8 mm), but in the noise frame a mission met, block matching mismatches the
whole skin of f01_0 (every point 30-35 mm behind it) and it came out 15 mm too far (11 mm
with the whole shift); the shear missed its peduncle.

Occluders: the fruit's part can hold points of something in front of the fruit (a stem or leaf
bridged into it, a neighbour), and where the skin has little texture they can be most of its
points, so the median followed them (renders: 70-100 mm too near). Each point in the core of the
silhouette (angular offset < EDGE_FRACTION alpha) gives the distance of the centre of the sphere of
angular radius alpha whose front passes through it; one fruit's points agree on it, so where the
sorted distances leave a gap of more than CLUSTER_GAP x the radius they imply, they are different
surfaces. Given the image, the fruit is the largest of those clusters whose radius D sin alpha is a
fruit's (FRUIT_RADIUS_RANGE) and whose pixels have the colour of the part (median chromaticity
within SKIN_CHROMA_TOL of the part's; highlight points count as skin): stems, leaves and a
neighbour of another colour are not the skin, and a mismatch behind the fruit has its colour but
few points. No such cluster, or no image: all points, as before. (A neighbour that is most of
the part sets the part's colour itself and is kept.) A neighbour of the same colour and size
whose part the detector joined to the fruit's passes both tests, and in front of a
textureless fruit it had the most points: long_row f19_3 came out 76 mm too near, behind
f19_1, and the suction cup closed on air. Where the circle is the fruit's own, its edge is
seen: the part's outline runs along the circle there (`outline_sectors`, from the detection's
mask), while the neighbour's points lie where the outline leaves the circle for the
neighbour's. So of several clusters that pass, one with a share of points in those sectors
larger than the largest cluster's by SECTOR_MARGIN is the fruit (points near the centre have
no sector and do not count). Where the neighbour in front covers the rest of the circle, the
part's outline runs along the whole circle and no sector tells them apart. But a sphere hides
everything behind it inside its silhouette: a passing cluster behind the chosen one, in the
core of the circle, is only seen if the chosen one is in front of the fruit. Block matching
also ranges patches of a smooth skin 3-4 cm behind it (renders: 91 such points behind a fully
visible fruit's 685), so the fruit is taken behind only when the chosen cluster is not the
circle's own skin: its centre distances tilt across the circle (`surface_tilt`, at least
BEHIND_MIN_TILT fruit radii per circle radius: 0.1-0.5 on the fruits' own skin, 0.6-11 on a
neighbour, but also 0.9-3.6 on two fully visible fruit whose circles were off), and the
cluster behind has at least BEHIND_MIN_SHARE of its points (`hidden_behind`). A tilt means
something only over a cluster that spans the circle: on a dim skin block matching ranged the
fruit's points as a small, steep patch (tilt 3-4, its offsets' spread 0.08 of the circle's
radius) with the backdrop behind it at half as many points, and the fruit was taken 150-210 mm
too far (low_light f00_0 in two of 16 noise-frame pairs). So a chosen cluster spanning less
than TILT_MIN_SPREAD stays the fruit unless the cluster behind has more points than it (the
four fruit the rule moves on renders are unchanged: two span 0.28-0.40, two have 6-40 times
fewer points than the cluster behind). On three seeds
of renders (664 located ripe fruit) that moves 4 fruit from 70-181 mm to 0.4-10 mm and none
the other way; with a share of 0.1 it also took 2 fully
visible fruit behind their skins (to 54 and 115 mm), while it moved long_row f19_3 from 27
to 2 mm in one of the four live noise frames (its crescent behind f19_1 has 15 % of f19_1's
points there). The part need not hold the fruit's skin at all: at long_row's point 19 the
detector gave the skin of f19_1 where f19_3 lies behind it to f19_3's part, and f19_1's part
held a piece of the turning fruit in front of f19_1 instead, so f19_1 was located at that
fruit's depth, 82 mm too near. So every location is checked against the points of the
detection's whole circle (`seen_through`): points off its part in the core of the circle
that are ranged behind the located sphere (centre distance more than CLUSTER_GAP radii beyond
its centre), at least SEEN_THROUGH_SHARE of the points on it, could not be seen through an
opaque fruit; the fruit is then at the depth cluster of the circle's points with a fruit's
radius that leaves fewer such points and has the most points on it, or has no 3D point.
Points of the part itself are not counted: block matching ranges patches of a smooth skin far
behind itself (0.1-0.6 m on renders), and the part's points were already weighed above.
A fruit with fewer than
min_points points in its core has only rim points, which block matching smears (a fruit outside
the left camera's view got its 18 points from the background, 300 mm too far): no 3D point.

Two fruit cannot fill the same space. A fruit half behind a neighbour of its colour keeps, after
the neighbour's circle is taken out, the points just outside that circle, which are the
neighbour's: block matching spreads the nearer surface's disparity half a window past its
edge, and a circle a pixel or two smaller than the silhouette leaves a crescent of it. So the
fruit behind was located at the neighbour's depth, its sphere deep inside the neighbour's
(renders: 76-170 mm too near). Where the spheres of two located fruit whose circles overlap
intersect by more than touching fruit's do (centres nearer than OVERLAP_GAP x the sum of their
radii), one of them is wrong: the one ranged on fewer than OVERLAP_SUPPORT_RATIO of the other's
cloud points per pixel of its circle has no 3D point (`unsupported_overlaps`, from the best
supported down): its depth rests on a few smeared pixels where the other's rests on its skin.
The other must itself rest on at least OVERLAP_MIN_SUPPORT points per pixel: on a dim,
textureless skin both have a few hundred points and their ratio says nothing (long_row's point
19, where f19_1 and f19_3 were both located at f19_1's depth on 0.01-0.08 points per pixel, and
the rule without that minimum withdrew f19_1, the right one, in 3 of the 16 noise-frame pairs;
low_light f00_1 in one, on 0.04 against 0.09; the renders' fruit that the rule mends lay
beside neighbours on 0.15-0.47). Fruit of a truss touch: dense_cluster's f00_6,
located right beside a neighbour at 1.00 of their radii's sum, lost its 3D point in 3 pairs
without the gap's tolerance. On three seeds of renders (120 frames each, with
`silhouette_cone`) the rule withdraws 12 locations, none within 17 mm of a fruit's centre: 5 of
fruit matched by the benchmark (18-116 mm off) and 7 of detections matched to no fruit. Seed
2's 3D error p95 5.5 -> 4.9 mm (224 -> 222 ripe fruit located), seeds 1 and 3 unchanged; the
mission scenarios' perception audit (tools/perception_audit.py, 16 noise-frame pairs per picking
point): no fruit located within its 12 mm in a pair loses that location.
"""
import math

import cv2
import numpy as np

#: points farther from the centre axis than this fraction of R are not used
EDGE_FRACTION = 0.8
#: fewest valid cloud points on a fruit for a 3D point
MIN_POINTS = 12
#: a point whose pixel is this many times as bright as the fruit's median is on its highlight
SPECULAR_RATIO = 1.4
#: highlight points further off the circle's centre than this fraction of its radius are
#: ranged as if at it (virtual_image_factor)
SPECULAR_MAX_SIN = 0.7
#: block matching ranges a highlight pixel this share of the way from the skin to the light's
#: virtual image (highlight_factor; module docstring)
VIRTUAL_IMAGE_SHARE = 0.75
#: centre-distance estimates further apart than this fraction of the radius are two surfaces
CLUSTER_GAP = 0.5
#: a fruit's 3D radius (m): image_processing.yaml min/max_fruit_radius, the suction sleeve's
FRUIT_RADIUS_RANGE = (0.018, 0.055)
#: a cluster whose pixels' median chromaticity is this close to the part's is the fruit's skin
SKIN_CHROMA_TOL = 0.1
#: angular sectors round the circle in which the part's outline is looked for (outline_sectors)
OUTLINE_BINS = 24
#: a part's outline pixel this close to the circle (fraction of its radius, at least 1.5 pixels
#: of the mask) follows it
OUTLINE_TOL = 0.06
#: silhouette_cone: a cone whose angular radius differs from the circle's by more than this
#: factor, or whose axis lies more than CONE_AXIS_SHIFT x the circle's angular radius off the
#: circle's centre ray, is not taken (renders: 0.86-1.22 and at most 0.30 over 1398 detections)
CONE_RADIUS_FACTOR = 1.35
CONE_AXIS_SHIFT = 0.5
#: a sector whose arc is this much covered by outline pixels on the circle is the fruit's edge
OUTLINE_COVER = 0.5
#: points nearer the circle's centre than this fraction of its radius have no sector
SECTOR_MIN_OFFSET = 0.35
#: of two same-coloured clusters, the one more in the outline's sectors by this fraction wins
SECTOR_MARGIN = 0.3
#: a passing cluster behind the chosen one, with at least this share of its points (and
#: min_points), is the fruit: the chosen one is in front of it (module docstring)
BEHIND_MIN_SHARE = 0.3
#: ... and only when the chosen cluster's centre distances tilt across the circle by at least
#: this many radii per circle radius (`surface_tilt`): it is not the fruit's own skin
BEHIND_MIN_TILT = 0.55
#: ... and only when the chosen cluster spans the circle enough for that tilt to mean something
#: (standard deviation of its points' offsets from the centre, in circle radii, along x or y),
#: unless the cluster behind has more points than it
TILT_MIN_SPREAD = 0.15
#: locate_all: a fruit is in front of another when its centre is nearer by this share of the
#: other's radius
FRONT_MARGIN = 1.0
#: own_skin: a part whose inner points lie in front of the located fruit at least this share
#: is mostly something in front of it, and the fruit's grade is taken from its own skin
OWN_SKIN_FRONT_SHARE = 0.5
#: seen_through: points off a fruit's part, in the core of its circle, ranged behind its
#: located sphere, at least this share of the points on that sphere (and MIN_POINTS): the
#: fruit is not there
SEEN_THROUGH_SHARE = 0.5
#: unsupported_overlaps: of two located fruit whose spheres intersect, the one with fewer than
#: this share of the other's cloud points per pixel of its circle has no 3D point
OVERLAP_SUPPORT_RATIO = 0.5
#: ... when their spheres overlap by more than touching fruit's do: centres nearer than this
#: share of their radii's sum (fruit of a truss touch, and each radius is a few % off)
OVERLAP_GAP = 0.9
#: ... and only against a location that rests on at least this many points per pixel of its
#: circle (a dim, textureless skin's few points say little about another fruit's)
OVERLAP_MIN_SUPPORT = 0.12


class FruitLocation(object):
    """Fruit centre and radius, in the cloud (left optical) frame."""

    __slots__ = ('centre', 'radius', 'points', 'surface', 'part_share')

    def __init__(self, centre, radius, points, surface, part_share=None):
        self.centre = np.asarray(centre, dtype=np.float64)
        self.radius = float(radius)
        self.points = int(points)          # valid cloud points used
        self.surface = np.asarray(surface, dtype=np.float64)   # median surface point
        # share of the points in the core of the detection's part that are the fruit as
        # located (its depth cluster); None: not known
        self.part_share = None if part_share is None else float(part_share)

    def __repr__(self):
        return 'FruitLocation(centre=%s, radius=%.4f, points=%d)' % (
            np.round(self.centre, 4).tolist(), self.radius, self.points)


def projection_params(p):
    """(fx, fy, cx, cy, baseline) from a 3x4 (or 12-list) right-camera projection matrix."""
    p = np.asarray(p, dtype=np.float64).reshape(3, 4)
    fx, fy, cx, cy = p[0, 0], p[1, 1], p[0, 2], p[1, 2]
    if fx <= 0 or fy <= 0:
        raise ValueError('projection matrix has no focal length')
    baseline = -p[0, 3] / fx
    return fx, fy, cx, cy, baseline


def sphere_image_axes(theta, alpha):
    """(centre, a, b) of a sphere's image in normalised image coordinates (the plane z = 1):
    the sphere's centre ray at `theta` from the optical axis, its angular radius `alpha`
    (theta + alpha < pi / 2). The image is an ellipse: its centre lies `centre` from the
    principal point along the radial direction (outward of the projected sphere centre), `a`
    is its semi-axis along that direction, `b` the one across it (b < a off the axis)."""
    t1, t2 = math.tan(theta + alpha), math.tan(theta - alpha)
    across = math.cos(theta) ** 2 - math.sin(alpha) ** 2
    return 0.5 * (t1 + t2), 0.5 * (t1 - t2), math.sin(alpha) / math.sqrt(max(across, 1e-12))


def sphere_ray(u, v, radius_px, fx, fy, cx, cy, iterations=20):
    """Unit direction to a sphere's centre and its angular radius from its image circle.

    The silhouette of a sphere is the section of a circular cone around the centre ray, so its
    image is an ellipse whose centre lies outward of the projected sphere centre, longer along
    the radial image direction (semi-axis a) than across it (b; a / b about 1 / cos theta, 1.1
    at the edge of a 66 degree field of view). The detector's circle is the least-squares
    circle of that outline: its centre is the ellipse's and its radius the mean (a + b) / 2
    (the Kasa fit of a whole ellipse's outline gives exactly that; sphere_image_axes). Along
    the radial direction the two silhouette edges are at angles theta_c +- alpha from the
    optical axis, so halving their sum and difference recovers theta_c and alpha from the
    ellipse's centre and a; a = radius * a / ((a + b) / 2) of the sphere found, repeated to
    a fixed point (from a = radius: a few steps). Reading the radius as a instead put every
    off-axis fruit too near (renders: 3D error median 1.3-1.45 mm, 0.84-0.97 with this).
    """
    x = (u - cx) / fx
    y = (v - cy) / fy
    rho = math.hypot(x, y)
    r = radius_px / math.sqrt(fx * fy)
    if rho < 1e-9:
        alpha = math.atan(r)
        return np.array([0.0, 0.0, 1.0]), alpha
    a = r
    for _ in range(iterations):
        t1 = math.atan(rho + a)
        t2 = math.atan(rho - a)
        theta = 0.5 * (t1 + t2)
        alpha = 0.5 * (t1 - t2)
        if theta + alpha >= 0.5 * math.pi - 1e-6:
            break           # no ellipse: the cone reaches the image plane's horizon
        _, semi_a, semi_b = sphere_image_axes(theta, alpha)
        new_a = r * semi_a / (0.5 * (semi_a + semi_b))
        if abs(new_a - a) <= 1e-12 * max(a, 1e-12):
            break
        a = new_a
    tan_t = math.tan(theta)
    d = np.array([x / rho * tan_t, y / rho * tan_t, 1.0])
    return d / np.linalg.norm(d), alpha


def cloud_from_disparity(disparity, fx, fy, cx, cy, baseline, cx_right=None):
    """Organized HxWx3 float32 cloud (left optical frame, NaN invalid) from a float disparity.

    Same geometry as stereo_image_proc / image_geometry: Z = fx * B / (d - (cx_l - cx_r)).
    Disparities <= 0 or non-finite are invalid (StereoBM marks those with minDisparity - 1).
    """
    if cx_right is None:
        cx_right = cx
    d = disparity.astype(np.float32) - np.float32(cx - cx_right)
    h, w = d.shape
    valid = np.isfinite(d) & (d > 0)
    z = np.full((h, w), np.nan, np.float32)
    z[valid] = np.float32(fx * baseline) / d[valid]
    us = (np.arange(w, dtype=np.float32) - np.float32(cx)) / np.float32(fx)
    vs = (np.arange(h, dtype=np.float32) - np.float32(cy)) / np.float32(fy)
    cloud = np.empty((h, w, 3), np.float32)
    cloud[..., 0] = us[None, :] * z
    cloud[..., 1] = vs[:, None] * z
    cloud[..., 2] = z
    return cloud


def points_on_fruit(cloud, detection, right_p, pixels=False):
    """Valid cloud points (Nx3, left optical frame) that project onto the detection's part;
    with `pixels`, (points, u, v) with their right-image pixel coordinates."""
    p = np.asarray(right_p, dtype=np.float64).reshape(3, 4)
    h, w = cloud.shape[:2]
    x0, y0, bw, bh = detection.box(w, h)
    empty = np.zeros((0, 3))
    if bw <= 0 or bh <= 0:
        return (empty, np.zeros(0), np.zeros(0)) if pixels else empty
    # rectified rows coincide; in the left image the fruit lies right of its right-image box
    block = cloud[y0:y0 + bh, x0:, :].reshape(-1, 3)
    z = block[:, 2]
    ok = np.isfinite(z) & (z > 0)
    pts = block[ok].astype(np.float64)
    if len(pts) == 0:
        return (pts, np.zeros(0), np.zeros(0)) if pixels else pts
    u = (p[0, 0] * pts[:, 0] + p[0, 1] * pts[:, 1] + p[0, 2] * pts[:, 2] + p[0, 3]) / pts[:, 2]
    v = (p[1, 0] * pts[:, 0] + p[1, 1] * pts[:, 1] + p[1, 2] * pts[:, 2] + p[1, 3]) / pts[:, 2]
    on = detection.contains(u, v)
    return (pts[on], u[on], v[on]) if pixels else pts[on]


def part_pixels(image, detection):
    """Nx3 BGR pixels of the detection's visible part in `image` (none when it is empty)."""
    h, w = image.shape[:2]
    x0, y0, bw, bh = detection.box(w, h)
    if bw <= 0 or bh <= 0:
        return np.zeros((0, 3), image.dtype)
    yy, xx = np.mgrid[y0:y0 + bh, x0:x0 + bw]
    return image[y0:y0 + bh, x0:x0 + bw][detection.contains(xx, yy)]


def _pixels(image, u, v):
    """BGR of the image pixels nearest to (u, v), Nx3."""
    h, w = image.shape[:2]
    ui = np.clip(np.rint(u).astype(np.int64), 0, w - 1)
    vi = np.clip(np.rint(v).astype(np.int64), 0, h - 1)
    return image[vi, ui]


def _chromaticity(bgr):
    bgr = np.asarray(bgr, dtype=np.float64) + 1.0
    return bgr / bgr.sum(axis=-1, keepdims=True)


def on_highlight(image, detection, u, v, ratio=SPECULAR_RATIO, part=None):
    """Per point (right-image pixel u, v): is it on the fruit's specular highlight, i.e. at
    least `ratio` times as bright (HSV value = max of B, G, R) as the median of the fruit's
    visible part in `image` (the BGR image the detection was made on)? part: its
    part_pixels, if known."""
    if len(u) == 0:
        return np.zeros(0, dtype=bool)
    if part is None:
        part = part_pixels(image, detection)
    if len(part) == 0:
        return np.zeros(len(u), dtype=bool)
    median = float(np.median(part.max(axis=1)))
    return _pixels(image, u, v).max(axis=1).astype(np.float64) >= ratio * max(median, 1.0)


def skin_colour_distance(image, detection, u, v, part=None):
    """Per point (right-image pixel u, v): distance of its pixel's chromaticity (B, G, R over
    their sum) from the median chromaticity of the detection's visible part (its
    part_pixels, if known); None when the part is empty."""
    if part is None:
        part = part_pixels(image, detection)
    if len(part) == 0:
        return None
    skin = np.median(_chromaticity(part), axis=0)
    return np.linalg.norm(_chromaticity(_pixels(image, u, v)) - skin, axis=1)


def virtual_image_factor(du, dv, radius_px, max_sin=SPECULAR_MAX_SIN, share=1.0):
    """Per highlight pixel at (du, dv) px from the circle's centre (radius radius_px): k such
    that the fruit's centre lies k R beyond the depth at which a horizontal stereo pair ranges
    the light's virtual image there (module docstring; 1/2 at the centre). share < 1: the
    depth `share` of the way from the skin (the mirror point, R cos theta in front of the
    centre) to that virtual image (highlight_factor)."""
    du = np.asarray(du, dtype=np.float64)
    dv = np.asarray(dv, dtype=np.float64)
    off = np.hypot(du, dv)
    sin_t = np.minimum(off / float(radius_px), max_sin)
    cos_t = np.sqrt(1.0 - sin_t * sin_t)
    # cos^2 of the angle between the image rows and the plane of incidence (any, at the centre)
    cos2_phi = np.where(off > 1e-9, du * du / np.maximum(off * off, 1e-18), 1.0)
    focal_h = 0.5 / (cos2_phi / cos_t + (1.0 - cos2_phi) * cos_t)     # over R
    return cos_t - share * focal_h


def highlight_factor(du, dv, radius_px, share=VIRTUAL_IMAGE_SHARE, max_sin=SPECULAR_MAX_SIN):
    """Per highlight pixel: k such that the fruit's centre lies k R beyond the depth at which
    block matching ranges that pixel, `share` of the way from the skin to the light's virtual
    image (virtual_image_factor)."""
    return virtual_image_factor(du, dv, radius_px, max_sin, share)


def centre_distances(t, lateral, sin_a, glint=None, factor=0.5):
    """Per point at depth t along the centre ray and `lateral` from it: distance of the centre
    of the sphere of angular radius alpha on that ray whose front passes through the point
    (|p - D axis| = D sin alpha, the far root); a highlight point is a virtual image with the
    centre `factor` R beyond it (per point, virtual_image_factor), D = t / (1 - factor sin
    alpha). Points outside the cone count as on it."""
    cos2 = 1.0 - sin_a * sin_a
    disc = np.maximum(t * t * sin_a * sin_a - cos2 * lateral * lateral, 0.0)
    dist = (t + np.sqrt(disc)) / cos2
    if glint is not None:
        dist = np.where(glint, t / (1.0 - factor * sin_a), dist)
    return dist


def depth_clusters(dist, sin_a, gap=CLUSTER_GAP):
    """Index arrays of the runs of sorted centre distances `dist` with no step larger than
    `gap` x the radius they imply (dist sin alpha), nearest first."""
    low = float(dist.min())
    if float(dist.max()) - low <= gap * sin_a * low:       # one surface: no sort needed
        return [np.arange(len(dist))]
    order = np.argsort(dist, kind='stable')
    ordered = dist[order]
    cuts = np.nonzero(np.diff(ordered) > gap * sin_a * ordered[:-1])[0] + 1
    return np.split(order, cuts)


def outline_sectors(detection, bins=OUTLINE_BINS, tol=OUTLINE_TOL, min_cover=OUTLINE_COVER):
    """Bool array of `bins` angular sectors round the detection's circle (sector i spans
    atan2(v - v0, u - u0) in [-pi + i w, -pi + (i + 1) w)) along which the outline of its part
    runs on the circle (outline pixels within `tol` of it for at least `min_cover` of the
    sector's arc; a boundary that only crosses the circle covers a pixel or two), widened by
    one sector each way: where the fruit's own edge is seen. None without a part mask."""
    on = outline_on_circle(detection, tol)
    if on is None:
        return None
    u, v = on
    counts = np.bincount(sector_index(u, v, bins), minlength=bins)
    # outline pixels (8-connected) along an arc: about its length in mask pixels
    arc = float(detection.radius_px) * float(detection.mask_scale) * 2.0 * math.pi / bins
    sectors = counts >= min_cover * arc
    return sectors | np.roll(sectors, 1) | np.roll(sectors, -1)


def outline_on_circle(detection, tol=OUTLINE_TOL):
    """(du, dv): offsets (full-resolution pixels) from the circle's centre of the outline pixels
    of the detection's part that lie within `tol` x its radius of its circle (at least 1.5
    pixels of the mask), i.e. where the fruit's own edge is seen; None without a part mask.
    Pixel centres, half a mask pixel inside the part's edge."""
    mask = detection.mask
    if mask is None or mask.size == 0:
        return None
    # the crop's own border is not an outline (erode's default border keeps those pixels)
    m = np.asarray(mask, dtype=np.uint8)
    edge = (m > 0) & ~(cv2.erode(m, np.ones((3, 3), np.uint8)) > 0)
    ys, xs = np.nonzero(edge)
    scale = float(detection.mask_scale)
    u = (xs + detection.mask_origin[0] + 0.5) / scale - 0.5 - detection.u
    v = (ys + detection.mask_origin[1] + 0.5) / scale - 0.5 - detection.v
    r = float(detection.radius_px)
    on = np.abs(np.hypot(u, v) - r) <= max(tol * r, 1.5 / scale)
    return u[on], v[on]


def silhouette_cone(detection, fx, fy, cx, cy, tol=OUTLINE_TOL, min_points=MIN_POINTS,
                    refits=2):
    """(unit direction to the sphere's centre, angular radius alpha) from the fruit's own
    outline (module docstring): the rays through the part's outline pixels on its circle
    (`outline_on_circle`, each pushed out the half mask pixel it lies inside the edge) all make
    the angle alpha with the centre ray c, m . w = 1 with w = c / cos(alpha): a linear least
    squares fit, refitted `refits` times without the rays more than three times the median
    angular misfit off the cone (at least a pixel's angle). Without a mask, with fewer than
    `min_points` such pixels, no cone that fits them or one the circle contradicts (its angular
    radius off the circle's by more than `CONE_RADIUS_FACTOR`, its axis more than
    `CONE_AXIS_SHIFT` x that radius off the circle's ray: an outline on a short arc of the circle
    constrains the cone poorly): `sphere_ray` of the circle."""
    circle = sphere_ray(detection.u, detection.v, detection.radius_px, fx, fy, cx, cy)
    on = outline_on_circle(detection, tol)
    if on is not None and len(on[0]) >= min_points:
        du, dv = on
        scale = float(detection.mask_scale)
        grow = 1.0 + (0.5 / scale) / np.maximum(np.hypot(du, dv), 1e-9)
        rays = np.c_[(detection.u + du * grow - cx) / fx, (detection.v + dv * grow - cy) / fy,
                     np.ones(len(du))]
        rays /= np.linalg.norm(rays, axis=1)[:, None]
        keep = np.ones(len(rays), dtype=bool)
        pixel = 1.0 / math.sqrt(fx * fy)
        cone = None
        for _ in range(refits + 1):
            if np.count_nonzero(keep) < min_points:
                break
            kept = rays[keep]
            try:        # the normal equations: 3 x 3
                w = np.linalg.solve(kept.T.dot(kept), kept.sum(axis=0))
            except np.linalg.LinAlgError:
                break
            norm = float(np.linalg.norm(w))
            if not 1.0 < norm < 1e6:
                break
            cone = (w / norm, math.acos(1.0 / norm))
            misfit = np.abs(np.arccos(np.clip(rays.dot(cone[0]), -1.0, 1.0)) - cone[1])
            keep = misfit <= max(3.0 * float(np.median(misfit[keep])), pixel)
        if cone is not None and _cone_agrees(cone, circle):
            return cone
    return circle


def _cone_agrees(cone, circle, factor=CONE_RADIUS_FACTOR, shift=CONE_AXIS_SHIFT):
    """Whether silhouette_cone's (axis, alpha) is within `factor` of the circle's sphere_ray
    in angular radius and its axis within `shift` x the circle's angular radius of its ray."""
    (axis, alpha), (c_axis, c_alpha) = cone, circle
    if not (c_alpha / factor <= alpha <= c_alpha * factor):
        return False
    return math.acos(min(1.0, float(np.dot(axis, c_axis)))) <= shift * c_alpha


def sector_index(du, dv, bins=OUTLINE_BINS):
    """Sector (outline_sectors) of each offset (du, dv) from the circle's centre."""
    a = np.arctan2(np.asarray(dv, dtype=np.float64), np.asarray(du, dtype=np.float64))
    return np.minimum(((a + math.pi) * (bins / (2.0 * math.pi))).astype(np.int64), bins - 1)


def fruit_cluster(clusters, dist, sin_a, colour, min_points=MIN_POINTS,
                  radius_range=FRUIT_RADIUS_RANGE, tol=SKIN_CHROMA_TOL, in_outline=None,
                  margin=SECTOR_MARGIN, behind_share=BEHIND_MIN_SHARE, offsets=None,
                  min_tilt=BEHIND_MIN_TILT, min_spread=TILT_MIN_SPREAD):
    """The cluster (index array) that is the fruit: of those with at least min_points points,
    a radius (median dist x sin alpha) in radius_range and a median colour distance <= tol, the
    largest; None when there is none. in_outline: per point, 1 when it lies in a sector where
    the part's outline follows the circle, 0 when not, NaN when it has no sector (near the
    centre): then a cluster more in those sectors than the largest by `margin` (fraction of its
    points with a sector) is the fruit, the largest one being a neighbour of the same colour in
    front of it or behind it (module docstring)."""
    fits = []
    for idx in clusters:
        if len(idx) < min_points:
            continue
        radius = float(np.median(dist[idx])) * sin_a
        if radius_range[0] <= radius <= radius_range[1] and float(np.median(colour[idx])) <= tol:
            fits.append(idx)
    if not fits:
        return None
    chosen = largest = max(fits, key=len)
    if in_outline is not None and len(fits) > 1:
        def share(idx):
            s = in_outline[idx]
            s = s[np.isfinite(s)]
            return float(s.mean()) if len(s) else 0.0

        best = max(fits, key=share)
        if share(best) >= share(largest) + margin:
            chosen = best
    if behind_share is None or offsets is None or len(fits) < 2:
        return chosen
    behind = hidden_behind(fits, chosen, dist, min_points, behind_share)
    # the tilt (a least-squares fit) only where there is a cluster behind to take
    if behind is chosen or surface_tilt(dist[chosen], offsets[chosen], sin_a) < min_tilt:
        return chosen
    if len(behind) <= len(chosen) and float(np.std(offsets[chosen], axis=0).max()) < min_spread:
        # a small patch: its tilt is an extrapolation across the circle, and block matching on
        # a dim skin ranges such patches steeply (the cluster behind was the backdrop)
        return chosen
    return behind


def surface_tilt(dist, offsets, sin_a):
    """How much the centre distances `dist` of a cluster's points change across the circle:
    the gradient of the plane + paraboloid fitted to them over `offsets` (N x 2, pixel offsets
    from the circle's centre over its radius), in fruit radii (median dist x sin alpha) per
    circle radius. On the fruit's own skin every point gives the same centre distance (0 up to
    noise); on another sphere seen through the circle they change across it."""
    if len(dist) < 4:
        return 0.0
    x, y = offsets[:, 0], offsets[:, 1]
    design = np.c_[np.ones(len(dist)), x, y, x * x + y * y]
    coef = np.linalg.lstsq(design, dist, rcond=None)[0]
    return float(math.hypot(coef[1], coef[2]) / max(float(np.median(dist)) * sin_a, 1e-9))


def hidden_behind(fits, chosen, dist, min_points=MIN_POINTS, min_share=BEHIND_MIN_SHARE):
    """The cluster of `fits` (index arrays into `dist`, passing fruit_cluster's tests) that is
    the fruit when `chosen` is not: a sphere hides everything behind it inside its silhouette,
    so a passing cluster behind the chosen one, in the core of the circle, can only be seen
    if the chosen one is in front of the fruit. Of those with at least min_points and
    min_share x the chosen one's points, the largest; `chosen` when there is none."""
    far = float(np.median(dist[chosen]))
    behind = [idx for idx in fits if idx is not chosen and float(np.median(dist[idx])) > far
              and len(idx) >= max(min_points, min_share * len(chosen))]
    return max(behind, key=len) if behind else chosen


def locate(cloud, detection, right_p, min_points=MIN_POINTS, iterations=3, image=None,
           specular_ratio=SPECULAR_RATIO, radius_range=FRUIT_RADIUS_RANGE, hidden=(),
           circle_points=None, cone=None):
    """FruitLocation of a detection (cloud frame), or None when too few valid points (in all,
    or in the core of its silhouette).

    image: the BGR image the detection was made on (the right rectified image); with it, points
    on the specular highlight are ranged as its virtual image, and of several depth clusters
    the fruit's skin is kept (module docstring). radius_range: a fruit's 3D radius (m).
    hidden: circles (u, v, radius_px) of fruit in front of this one: their points are not its
    (`locate_all`). circle_points: the detection's points_in_circle, if known; cone: its
    silhouette_cone, if known."""
    fx, fy, cx, cy, baseline = projection_params(right_p)
    pts, pu, pv = points_on_fruit(cloud, detection, right_p, pixels=True) \
        if circle_points is None else _on_part(detection, circle_points)
    if len(hidden):
        mine = np.ones(len(pts), dtype=bool)
        for hu, hv, hr in hidden:
            mine &= np.hypot(pu - hu, pv - hv) > hr
        pts, pu, pv = pts[mine], pu[mine], pv[mine]
    if len(pts) < min_points:
        return None
    part = part_pixels(image, detection) if image is not None else None
    glint = on_highlight(image, detection, pu, pv, specular_ratio, part) \
        if image is not None else np.zeros(len(pts), dtype=bool)
    factor = highlight_factor(pu - detection.u, pv - detection.v, detection.radius_px) \
        if glint.any() else np.full(len(pts), 0.5)
    offset = np.array([baseline, 0.0, 0.0])     # right camera centre in the left frame
    pr = pts - offset
    axis, alpha = silhouette_cone(detection, fx, fy, cx, cy) if cone is None else cone
    t = pr.dot(axis)
    lateral = np.linalg.norm(pr - t[:, None] * axis[None, :], axis=1)
    sin_a = math.sin(alpha)
    core = np.nonzero(lateral < math.tan(EDGE_FRACTION * alpha) * t)[0]
    if len(core) < min_points:
        return None
    part_share = 1.0        # every point is the fruit's, unless a cluster is chosen below
    if image is not None:
        centre_d = centre_distances(t[core], lateral[core], sin_a, glint[core], factor[core])
        clusters = depth_clusters(centre_d, sin_a)
        colour = skin_colour_distance(image, detection, pu[core], pv[core], part) \
            if len(clusters) > 1 else None
        if colour is not None:
            colour[glint[core]] = 0.0
            sectors = outline_sectors(detection)
            in_outline = None
            if sectors is not None:
                du, dv = pu[core] - detection.u, pv[core] - detection.v
                in_outline = np.where(
                    np.hypot(du, dv) >= SECTOR_MIN_OFFSET * detection.radius_px,
                    sectors[sector_index(du, dv)].astype(np.float64), np.nan)
            offsets = np.c_[pu[core] - detection.u, pv[core] - detection.v] / detection.radius_px
            fruit = fruit_cluster(clusters, centre_d, sin_a, colour, min_points, radius_range,
                                  in_outline=in_outline, offsets=offsets)
            part_share = None if fruit is None else len(fruit) / float(len(core))
            if fruit is not None:
                keep = core[fruit]
                pts, pr, t, lateral, glint = pts[keep], pr[keep], t[keep], lateral[keep], \
                    glint[keep]
                factor = factor[keep]
    # start: the median surface depth pushed back by the radius it implies
    t_med = float(np.median(t))
    dist = t_med / max(1.0 - sin_a, 1e-6) if sin_a < 1.0 else t_med
    radius = dist * sin_a
    for _ in range(iterations):
        near = lateral < EDGE_FRACTION * radius
        if near.sum() < min_points:
            near = lateral <= np.partition(lateral, min_points - 1)[min_points - 1]
        est = np.where(glint[near], t[near] + factor[near] * radius,
                       t[near] + np.sqrt(np.maximum(radius * radius - lateral[near] ** 2, 0.0)))
        dist = float(np.median(est))
        radius = dist * sin_a
    surface = np.median(pr[lateral < EDGE_FRACTION * radius], axis=0) \
        if (lateral < EDGE_FRACTION * radius).any() else np.median(pr, axis=0)
    return FruitLocation(dist * axis + offset, radius, len(pts), surface + offset, part_share)


def locate_all(cloud, detections, right_p, image=None, radius_range=FRUIT_RADIUS_RANGE,
               **kwargs):
    """FruitLocation (or None) of every detection, as `locate`, with the fruit's order in
    depth: a sphere hides what lies behind it inside its silhouette, so where two circles
    overlap, the points inside the circle of the one in front are not the other's. One pass
    over the first locations; for each detection whose circle overlaps others':
    - some located in front of it (centre nearer by FRONT_MARGIN of its radius or more): it
      is located again without the points inside their circles; too few left: no 3D point
      (what it had were theirs);
    - else some located at its depth (within that margin): two fruit of overlapping circles
      cannot both be there, one took the other's points. Located again without their
      circles, it is the fruit behind them when that puts it behind them by the margin; with
      too few points left, while each of them has min_points outside this circle, it has no
      3D point; otherwise it keeps its first location.
    Then every location is checked against the points of the detection's whole circle
    (`seen_through`), and last, of two located fruit whose spheres intersect, one ranged on
    far fewer points per pixel of its circle than the other has no 3D point
    (`unsupported_overlaps`).
    Cost: at most one more `locate` per detection (and a point count per overlapping pair),
    only where circles overlap, and one pass over each circle's points and outline."""
    kwargs = dict(kwargs, image=image, radius_range=radius_range)
    # each detection's circle points, projected once for all that follows
    circles = [points_in_circle(cloud, d, right_p) for d in detections]
    # and each one's centre ray and angular radius
    fx, fy, cx, cy, _ = projection_params(right_p)
    cones = [silhouette_cone(d, fx, fy, cx, cy) for d in detections]
    first = [locate(cloud, d, right_p, circle_points=c, cone=k, **kwargs)
             for d, c, k in zip(detections, circles, cones)]
    dists = [None if loc is None else float(np.linalg.norm(loc.centre)) for loc in first]
    out = list(first)
    for i, (d, loc) in enumerate(zip(detections, first)):
        if loc is None:
            continue
        margin = FRONT_MARGIN * loc.radius
        over = [j for j, o in enumerate(detections) if j != i and first[j] is not None
                and _circles_overlap(o, d)]
        ahead = [j for j in over if dists[j] < dists[i] - margin]
        level = [j for j in over if abs(dists[j] - dists[i]) <= margin]
        if ahead:
            out[i] = locate(cloud, d, right_p, hidden=_circles(detections, ahead),
                            circle_points=circles[i], cone=cones[i], **kwargs)
        elif level:
            again = locate(cloud, d, right_p, hidden=_circles(detections, level),
                           circle_points=circles[i], cone=cones[i], **kwargs)
            if again is not None:
                if float(np.linalg.norm(again.centre)) > max(dists[j] for j in level) + margin:
                    out[i] = again
            elif all(_points_outside(detections[j], circles[j], d) >= MIN_POINTS
                     for j in level):
                out[i] = None
    # each location against the points of its whole circle
    out = [None if loc is None else seen_through(cloud, d, right_p, loc, image, radius_range,
                                                 circle_points=c, cone=k)
           for d, loc, c, k in zip(detections, out, circles, cones)]
    # last, two fruit cannot fill the same space
    withdrawn = unsupported_overlaps(detections, out)
    return [None if i in withdrawn else loc for i, loc in enumerate(out)]


def unsupported_overlaps(detections, locations, ratio=OVERLAP_SUPPORT_RATIO, gap=OVERLAP_GAP,
                         min_support=OVERLAP_MIN_SUPPORT):
    """Indices of the locations to withdraw (module docstring). Each location's support is its
    cloud points per pixel of its detection's circle; from the best supported down, a location
    is withdrawn when its circle overlaps and its sphere intersects (centres nearer than `gap`
    x the sum of their radii) that of a location kept with at least `min_support` and more
    than 1 / `ratio` times its support (a withdrawn one withdraws none). Two fruit ranged alike
    both stay. locations: FruitLocation or None per detection."""
    support = {i: loc.points / (math.pi * max(detections[i].radius_px, 1.0) ** 2)
               for i, loc in enumerate(locations) if loc is not None}
    kept, withdrawn = [], set()
    for i in sorted(support, key=lambda k: -support[k]):
        a, da = locations[i], detections[i]
        for j in kept:
            b, db = locations[j], detections[j]
            if support[j] >= min_support and support[i] < ratio * support[j] and \
                    _circles_overlap(da, db) and \
                    np.linalg.norm(a.centre - b.centre) < gap * (a.radius + b.radius):
                withdrawn.add(i)
                break
        else:
            kept.append(i)
    return withdrawn


def _circles_overlap(a, b):
    """Do the circles of detections a and b overlap in the image?"""
    return math.hypot(a.u - b.u, a.v - b.v) < a.radius_px + b.radius_px


def points_in_circle(cloud, detection, right_p):
    """(points, u, v): the valid cloud points (left optical frame) that project into the
    detection's circle in the right image, whatever part they are on, with their pixel
    coordinates there."""
    p = np.asarray(right_p, dtype=np.float64).reshape(3, 4)
    h, w = cloud.shape[:2]
    x0, y0, bw, bh = detection.box(w, h)
    if bw <= 0 or bh <= 0:
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0)
    # rectified rows coincide; in the left image the fruit lies right of its right-image box
    block = cloud[y0:y0 + bh, x0:, :].reshape(-1, 3)
    z = block[:, 2]
    pts = block[np.isfinite(z) & (z > 0)].astype(np.float64)
    u = (p[0, 0] * pts[:, 0] + p[0, 1] * pts[:, 1] + p[0, 2] * pts[:, 2] + p[0, 3]) / pts[:, 2]
    v = (p[1, 0] * pts[:, 0] + p[1, 1] * pts[:, 1] + p[1, 2] * pts[:, 2] + p[1, 3]) / pts[:, 2]
    on = (u - detection.u) ** 2 + (v - detection.v) ** 2 <= detection.radius_px ** 2
    return pts[on], u[on], v[on]


def _on_part(detection, circle_points):
    """points_on_fruit's (points, u, v) from the detection's points_in_circle (the same
    points, in the same order)."""
    pts, pu, pv = circle_points
    on = detection.contains(pu, pv)
    return pts[on], pu[on], pv[on]


def _circle_rays(cloud, detection, right_p, circle_points=None, cone=None):
    """The points of the detection's circle (points_in_circle, or `circle_points`) on its
    centre ray (silhouette_cone, or `cone`): (u, v, points relative to the right camera, t
    along the ray, lateral offset from it, the ray's axis, its angular radius alpha, the right
    camera's centre in the cloud frame)."""
    fx, fy, cx, cy, baseline = projection_params(right_p)
    pts, pu, pv = points_in_circle(cloud, detection, right_p) if circle_points is None \
        else circle_points
    offset = np.array([baseline, 0.0, 0.0])
    pr = pts - offset
    axis, alpha = silhouette_cone(detection, fx, fy, cx, cy) if cone is None else cone
    t = pr.dot(axis)
    lateral = np.linalg.norm(pr - t[:, None] * axis[None, :], axis=1)
    return pu, pv, pr, t, lateral, axis, alpha, offset


def _ranged_centre_distances(image, detection, pu, pv, t, lateral, sin_a):
    """(centre distances, on the highlight?) of points of a circle, as `locate` ranges them:
    highlight points (given the image) as the light's virtual image."""
    glint = on_highlight(image, detection, pu, pv) if image is not None else \
        np.zeros(len(t), dtype=bool)
    factor = highlight_factor(pu - detection.u, pv - detection.v, detection.radius_px) \
        if glint.any() else np.full(len(t), 0.5)
    return centre_distances(t, lateral, sin_a, glint, factor), glint


def seen_through(cloud, detection, right_p, loc, image=None, radius_range=FRUIT_RADIUS_RANGE,
                 min_points=MIN_POINTS, share=SEEN_THROUGH_SHARE, circle_points=None,
                 cone=None):
    """The detection's location `loc` checked against the points of its whole circle (module
    docstring): `loc` when too few points off its part are seen behind it, else the depth
    cluster of the circle's core points with a fruit's radius that leaves too few and has the
    most points on its sphere (a FruitLocation at its median centre distance), else None.
    circle_points: the detection's points_in_circle, if known; cone: its silhouette_cone."""
    pu, pv, pr, t, lateral, axis, alpha, offset = _circle_rays(cloud, detection, right_p,
                                                               circle_points, cone)
    core = np.nonzero(lateral < math.tan(EDGE_FRACTION * alpha) * t)[0]
    foreign = ~detection.contains(pu[core], pv[core])
    if np.count_nonzero(foreign) < min_points:
        return loc
    pu, pv, pr, t, lateral = pu[core], pv[core], pr[core], t[core], lateral[core]
    sin_a = math.sin(alpha)
    here = float((loc.centre - offset).dot(axis))
    # a highlight point is pushed back by k R, at most the sphere's thickness there, so its
    # centre distance is no farther than a skin point's at its place: too few points behind
    # without the highlights is too few with them (the usual case, decided without the image)
    if np.count_nonzero(foreign & (centre_distances(t, lateral, sin_a) >
                                   here * (1.0 + CLUSTER_GAP * sin_a))) < min_points:
        return loc
    dist, _ = _ranged_centre_distances(image, detection, pu, pv, t, lateral, sin_a)

    def verdict(centre):
        """(too many points off the part seen behind a sphere at centre distance `centre`?,
        points on it)"""
        gap = CLUSTER_GAP * centre * sin_a
        behind = int(np.count_nonzero(foreign & (dist > centre + gap)))
        on = int(np.count_nonzero(np.abs(dist - centre) <= gap))
        return behind >= max(min_points, share * on), on

    if not verdict(here)[0]:
        return loc
    best = None
    for idx in depth_clusters(dist, sin_a):
        if len(idx) < min_points:
            continue
        centre = float(np.median(dist[idx]))
        if not radius_range[0] <= centre * sin_a <= radius_range[1]:
            continue
        seen, on = verdict(centre)
        if not seen and (best is None or on > best[2]):
            best = (centre, idx, on)
    if best is None:
        return None
    centre, idx, _ = best
    own = ~foreign
    on_part = np.count_nonzero(own & (np.abs(dist - centre) <= CLUSTER_GAP * centre * sin_a))
    return FruitLocation(centre * axis + offset, centre * sin_a, len(idx),
                         np.median(pr[idx], axis=0) + offset,
                         on_part / float(max(np.count_nonzero(own), 1)))


def own_skin(cloud, detection, right_p, loc, image=None, min_points=2 * MIN_POINTS,
             share=OWN_SKIN_FRONT_SHARE):
    """Right-image pixels (u, v) of the located fruit's own skin, to grade it by, when its
    part is mostly something in front of it; else None. The detector grades a fruit by the
    colour of its part, and a part can be mostly another fruit in front of it (long_row
    f19_1, whose region held the orange half of the turning fruit f19_0 in front of it: 0.64
    for a fruit of 0.91). Depth tells them apart: when at least `share` of the part's points
    within 0.85 r lie in front of the located sphere (centre distance more than CLUSTER_GAP
    radii nearer), the pixels of the circle's points within 0.85 r on that sphere (off the
    highlight), at least `min_points` of them, are the skin."""
    pu, pv, _, t, lateral, axis, alpha, offset = _circle_rays(cloud, detection, right_p)
    inner = np.hypot(pu - detection.u, pv - detection.v) <= 0.85 * detection.radius_px
    if np.count_nonzero(inner) < min_points:
        return None
    pu, pv, t, lateral = pu[inner], pv[inner], t[inner], lateral[inner]
    sin_a = math.sin(alpha)
    dist, glint = _ranged_centre_distances(image, detection, pu, pv, t, lateral, sin_a)
    here = float((loc.centre - offset).dot(axis))
    gap = CLUSTER_GAP * here * sin_a
    part = detection.contains(pu, pv)
    if not part.any() or np.count_nonzero(part & (dist < here - gap)) < \
            share * np.count_nonzero(part):
        return None
    on = (np.abs(dist - here) <= gap) & ~glint
    if np.count_nonzero(on) < min_points:
        return None
    return pu[on], pv[on]


def regrade(detector, cloud, found, right_p, image):
    """[(detection, location)] with each located fruit whose part is mostly something in
    front of it graded by its own skin instead (own_skin; detector.grade_at on `image`, the
    BGR image the detections were made on), as a copy of its detection with that score; the
    others as they are (all of them without an image)."""
    out = []
    for det, loc in found:
        # a location taken from the part's own points (most of them on the fruit) cannot have
        # a part mostly in front of it: no need to look
        if loc is not None and image is not None and not (
                loc.part_share is not None and loc.part_share > 1.0 - OWN_SKIN_FRONT_SHARE):
            skin = own_skin(cloud, det, right_p, loc, image)
            if skin is not None:
                score = detector.grade_at(image, skin[0], skin[1])
                if score is not None:
                    det = det.with_score(score)
        out.append((det, loc))
    return out


def _points_outside(detection, circle_points, other):
    """How many of a detection's cloud points (on its part, from its points_in_circle) lie
    outside another detection's circle (a count, cheaper than locating it again)."""
    _, pu, pv = _on_part(detection, circle_points)
    return int(np.count_nonzero(np.hypot(pu - other.u, pv - other.v) > other.radius_px))


def _circles(detections, indices):
    return [(detections[j].u, detections[j].v, detections[j].radius_px) for j in indices]


def cloud_array(data, height, width, point_step, row_step, offsets, big_endian=False):
    """Organized HxWx3 float32 xyz array from PointCloud2 fields (x, y, z float32 offsets)."""
    endian = '>' if big_endian else '<'
    dtype = np.dtype({'names': ['x', 'y', 'z'], 'formats': [endian + 'f4'] * 3,
                      'offsets': list(offsets), 'itemsize': point_step})
    buf = np.frombuffer(data, dtype=np.uint8)
    if row_step != width * point_step:
        buf = buf.reshape(height, row_step)[:, :width * point_step]
        buf = np.ascontiguousarray(buf).reshape(-1)
    recs = np.frombuffer(buf, dtype=dtype, count=height * width)
    out = np.empty((height, width, 3), np.float32)
    out[..., 0] = recs['x'].reshape(height, width)
    out[..., 1] = recs['y'].reshape(height, width)
    out[..., 2] = recs['z'].reshape(height, width)
    return out


#: stereo_image_proc dynamic_reconfigure parameter -> cv2.StereoBM setter, for the offline cloud
BM_SETTERS = (
    ('prefilter_size', 'setPreFilterSize'),
    ('prefilter_cap', 'setPreFilterCap'),
    ('correlation_window_size', 'setBlockSize'),
    ('min_disparity', 'setMinDisparity'),
    ('disparity_range', 'setNumDisparities'),
    ('uniqueness_ratio', 'setUniquenessRatio'),
    ('texture_threshold', 'setTextureThreshold'),
    ('speckle_size', 'setSpeckleWindowSize'),
    ('speckle_range', 'setSpeckleRange'),
    ('disp12MaxDiff', 'setDisp12MaxDiff'),
)


def stereo_bm_from_params(params):
    """cv2.StereoBM configured like stereo_image_proc with the given parameter dict."""
    import cv2
    if int(params.get('stereo_algorithm', 0)) != 0:
        raise ValueError('only block matching (stereo_algorithm 0) is reproduced offline')
    bm = cv2.StereoBM_create()
    for key, setter in BM_SETTERS:
        if key in params:
            getattr(bm, setter)(int(params[key]))
    return bm


def offline_cloud(left_bgr, right_bgr, params, fx, fy, cx, cy, baseline):
    """stereo_image_proc's points2 recomputed offline: mono conversion, StereoBM, reprojection."""
    import cv2
    bm = stereo_bm_from_params(params)
    left = cv2.cvtColor(left_bgr, cv2.COLOR_BGR2GRAY)
    right = cv2.cvtColor(right_bgr, cv2.COLOR_BGR2GRAY)
    raw = bm.compute(left, right)
    disp = raw.astype(np.float32) / 16.0
    disp[raw < int(params.get('min_disparity', 0)) * 16] = np.nan
    return cloud_from_disparity(disp, fx, fy, cx, cy, baseline)
