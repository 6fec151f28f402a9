"""Reference point-feature IBVS law in plain numpy, used ONLY by the tests.

Features of the fruit centre: the point s = (x, y) in normalized image coordinates and the depth
feature log(Z / Z*). With the interaction matrix L at the current features,

    v = -lambda * pinv(L) * e,    e = (x - x*, y - y*, log(Z / Z*)),

v = (vx, vy, vz, wx, wy, wz) in the camera frame. In translation mode the rotation columns of L
are removed (the SCARA arm only translates), so v_t = -lambda * pinv(L_t) * e and w = 0.
Adaptive gain (as ViSP's vpServo applies vpAdaptiveGain): lambda = (l0 - linf) * exp(-slope0 /
(l0 - linf) * |e1|_inf) + linf, evaluated at e1 = pinv(L) * e (the velocity before the gain).
Written from the textbook formulas (Chaumette and Hutchinson 2006), independent of ViSP.
"""

import math

import numpy as np


def point_interaction(x, y, z):
    """2x6 interaction matrix of a normalized image point at depth z."""
    return np.array([[-1.0 / z, 0.0, x / z, x * y, -(1.0 + x * x), y],
                     [0.0, -1.0 / z, y / z, 1.0 + y * y, -x * y, -x]])


def depth_interaction(x, y, z):
    """1x6 interaction matrix of the feature log(Z / Z*)."""
    return np.array([[0.0, 0.0, -1.0 / z, -y, x, 0.0]])


def interaction(x, y, z):
    """3x6 interaction matrix of (x, y, log Z / Z*)."""
    return np.vstack([point_interaction(x, y, z), depth_interaction(x, y, z)])


def feature_error(cur, des):
    """e = (x - x*, y - y*, log(Z / Z*)) for features (x, y, Z)."""
    return np.array([cur[0] - des[0], cur[1] - des[1], math.log(cur[2] / des[2])])


def gain_value(e1, gain, gain_inf=None, slope=None):
    """Constant gain, or the adaptive gain at the infinity norm of e1 = pinv(L) e."""
    if gain_inf is None:
        return gain
    a = gain - gain_inf
    return a * math.exp(-slope / a * float(np.max(np.abs(e1)))) + gain_inf


def control_law(cur, des, gain, translation_only=True, gain_inf=None, slope=None):
    """Camera velocity (6,) for current/desired features (x, y, Z)."""
    v, _ = control_law_and_gain(cur, des, gain, translation_only, gain_inf, slope)
    return v


def control_law_and_gain(cur, des, gain, translation_only=True, gain_inf=None, slope=None):
    """(camera velocity (6,), gain used) for current/desired features (x, y, Z)."""
    big_l = interaction(*cur)
    e = feature_error(cur, des)
    e1 = np.zeros(6)
    if translation_only:
        e1[:3] = np.linalg.pinv(big_l[:, :3]).dot(e)
    else:
        e1 = np.linalg.pinv(big_l).dot(e)
    lam = gain_value(e1, gain, gain_inf, slope)
    return -lam * e1, lam


def point_of(feature):
    """3D point (x Z, y Z, Z) of a feature."""
    x, y, z = feature
    return np.array([x * z, y * z, z])


def error_at_target(cur, des):
    """|P - P*| in metres."""
    return float(np.linalg.norm(point_of(cur) - point_of(des)))
