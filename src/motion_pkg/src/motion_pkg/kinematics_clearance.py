"""Collision checks of the two arms (pure numpy): the shortest distance between 3-D segments and
the clearance between the arms' forearm+tool segments, which kinematics.RobotGeometry.inverse
keeps at least robot.yaml's arm_clearance."""

import math

import numpy as np

from motion_pkg.kinematics_geometry import OTHER_ARM

#: sin^2 of the angle between two segments below which segment_distance finds its s from the
#: offsets of one segment's ends from the other's line (_near_parallel_s), not the closed form
NEAR_PARALLEL = 1e-6


def segment_distance(p1, q1, p2, q2):
    """Shortest distance between 3-D segments p1-q1 and p2-q2."""
    p1, q1, p2, q2 = (np.asarray(v, dtype=float) for v in (p1, q1, p2, q2))
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f = d1.dot(d1), d2.dot(d2), d2.dot(r)
    eps = 1e-15
    if a <= eps and e <= eps:
        s, t = 0.0, 0.0                # two (near-)points: the endpoint distances below decide
    elif a <= eps:
        s, t = 0.0, min(max(f / e, 0.0), 1.0)
    else:
        c = d1.dot(r)
        if e <= eps:
            t, s = 0.0, min(max(-c / a, 0.0), 1.0)
        else:
            b = d1.dot(d2)
            denom = a * e - b * b
            # parallel segments have denom 0: any other pair of directions gets the closed form
            # (near-parallel segments may cross), whose clamped s and t always name real points
            # of both segments; the endpoint distances below cover the parallel case exactly
            if denom > NEAR_PARALLEL * a * e:
                s = min(max((b * f - c * e) / denom, 0.0), 1.0)
            elif denom > 0.0:
                s = _near_parallel_s(d1, d2, r, e)
            else:
                s = 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t, s = 0.0, min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t, s = 1.0, min(max((b - c) / a, 0.0), 1.0)
    best = float(np.linalg.norm((p1 + d1 * s) - (p2 + d2 * t)))
    # near-degenerate (sub-micrometre) segments lose precision in the closed form: the
    # endpoint-to-segment distances bound the answer exactly
    return min(best, _point_segment(p1, p2, q2), _point_segment(q1, p2, q2),
               _point_segment(p2, p1, q1), _point_segment(q2, p1, q1))


def _near_parallel_s(d1, d2, r, e):
    """s of segment 1's point nearest to the line of segment 2 when the two nearly run parallel.

    The closed form divides by a * e - b * b, which cancels there: for directions 1e-7 rad apart
    its s was 2.5 % off and the distance of two crossing segments came out 2.5e-9 m instead of 0.
    The offsets of segment 1's ends from line 2 are computed without that cancellation, and
    segment 1's offset from the line is linear in s between them."""
    u = d2 / math.sqrt(e)
    o0 = r - u * u.dot(r)                  # p1's offset from line 2 (r = p1 - p2)
    q = r + d1
    do = (q - u * u.dot(q)) - o0           # q1's offset minus p1's
    dd = do.dot(do)
    return min(max(-o0.dot(do) / dd, 0.0), 1.0) if dd > 0.0 else 0.0


def _point_segment(p, a, b):
    """Distance from point p to segment a-b."""
    d = b - a
    dd = d.dot(d)
    t = 0.0 if dd <= 0.0 else min(max((p - a).dot(d) / dd, 0.0), 1.0)
    return float(np.linalg.norm(p - (a + d * t)))


class ArmClearance(object):
    """Mixin of kinematics.RobotGeometry: the arms' clearance (uses its arm_points)."""

    def clearance(self, arm, joints, other_joints, waist=0.0):
        """Distance between this arm's and the other arm's forearm+tool segments."""
        _, e1, t1 = self.arm_points(arm, *joints, waist=waist)
        _, e2, t2 = self.arm_points(OTHER_ARM[arm], *other_joints, waist=waist)
        return segment_distance(e1, t1, e2, t2)
