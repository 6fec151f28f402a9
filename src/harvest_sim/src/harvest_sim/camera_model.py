"""Pinhole camera model shared by the renderer, the scenario generator and the camera node.

Pixel convention (OpenCV / ROS camera_info): the centre of pixel (u, v) is at (u, v); a point
(x, y, z) in the optical frame (z forward, x right, y down) projects to
u = fx x / z + cx, v = fy y / z + cy.
"""

import math

import numpy as np

#: Bumblebee2-like stereo head (BB2-08S2 with a ~66 deg lens)
STEREO_WIDTH, STEREO_HEIGHT, STEREO_HFOV_DEG = 1024, 768, 66.0
#: eye-in-hand camera on the cutting hand
HAND_WIDTH, HAND_HEIGHT, HAND_HFOV_DEG = 640, 480, 60.0


class PinholeCamera(object):
    """Ideal pinhole camera (no distortion)."""

    def __init__(self, width, height, fx, fy=None, cx=None, cy=None):
        self.width = int(width)
        self.height = int(height)
        self.fx = float(fx)
        self.fy = float(fx if fy is None else fy)
        self.cx = float((self.width - 1) / 2.0 if cx is None else cx)
        self.cy = float((self.height - 1) / 2.0 if cy is None else cy)
        if self.width <= 0 or self.height <= 0 or self.fx <= 0.0 or self.fy <= 0.0:
            raise ValueError('camera size and focal length must be positive')

    @classmethod
    def from_hfov(cls, width, height, hfov_deg):
        """Square pixels, principal point at the image centre, horizontal field of view."""
        if not 1.0 < hfov_deg < 179.0:
            raise ValueError('hfov_deg %r outside (1, 179)' % hfov_deg)
        fx = (width / 2.0) / math.tan(math.radians(hfov_deg) / 2.0)
        return cls(width, height, fx)

    @property
    def K(self):
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    def P(self, tx=0.0):
        """3x4 projection matrix; tx = -fx * baseline for the right camera of a stereo pair."""
        return np.array([[self.fx, 0.0, self.cx, tx], [0.0, self.fy, self.cy, 0.0],
                         [0.0, 0.0, 1.0, 0.0]])

    def hfov_deg(self):
        return math.degrees(2.0 * math.atan(self.width / 2.0 / self.fx))

    def project(self, pts):
        """(N,3) points in the optical frame -> (N,2) pixels (z must be > 0)."""
        p = np.atleast_2d(np.asarray(pts, dtype=float))
        return np.stack([self.fx * p[:, 0] / p[:, 2] + self.cx,
                         self.fy * p[:, 1] / p[:, 2] + self.cy], axis=1)

    def ray_grid(self):
        """(xs, ys): normalised ray coordinates of every pixel column (W,) and row (H,)."""
        xs = (np.arange(self.width, dtype=np.float64) - self.cx) / self.fx
        ys = (np.arange(self.height, dtype=np.float64) - self.cy) / self.fy
        return xs, ys


def stereo_camera():
    return PinholeCamera.from_hfov(STEREO_WIDTH, STEREO_HEIGHT, STEREO_HFOV_DEG)


def hand_camera():
    return PinholeCamera.from_hfov(HAND_WIDTH, HAND_HEIGHT, HAND_HFOV_DEG)


def to_camera(T_map_cam, pts_map):
    """(N,3) map points into the camera frame whose pose in map is T_map_cam (4x4)."""
    R, t = T_map_cam[:3, :3], T_map_cam[:3, 3]
    return (np.atleast_2d(np.asarray(pts_map, dtype=float)) - t).dot(R)
