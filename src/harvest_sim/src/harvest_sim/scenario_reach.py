"""Kinematics of a scenario: is a fruit reachable from its picking point, is it in view.

Reachability with motion_pkg's RobotGeometry (suction tcp on the fruit, shear tcp on the
peduncle, waist at 0 or turned by inverse_waist), the stereo eyes' poses at a picking point and
whether a fruit lies fully inside both stereo images.
"""

import math

import numpy as np

from harvest_sim import camera_model
from harvest_sim.scenario_model import default_peduncle

def reachability(geom, position, radius, cart_y, peduncle=None, waist=True):
    """(reachable, reason) of a fruit with the cart at cart_y.

    Size: the fruit's radius within the suction sleeve's range (robot.yaml
    robot.arms.right.fruit_radius, when given).
    Right arm: suction tcp on the fruit surface facing it (target the centre, standoff radius).
    Left arm: shear tcp on the peduncle, with the right arm at that suction pose.
    waist True: at waist 0 or, if not there, at the smallest waist rotation that serves both
    arms (the robot's kinematics action, RobotGeometry.inverse_waist); False: at waist 0 only.
    """
    radii = getattr(geom, 'fruit_radius', {}).get('right')
    if radii is not None and not radii[0] <= radius <= radii[1]:
        return False, 'suction: a fruit of radius %.0f mm does not fit the suction sleeve ' \
            '(%.0f-%.0f mm, robot.yaml)' % (radius * 1e3, radii[0] * 1e3, radii[1] * 1e3)
    base = np.array([0.0, cart_y, 0.0])
    c = np.asarray(position, dtype=float) - base
    ped = (default_peduncle(position, radius) if peduncle is None else
           np.asarray(peduncle, dtype=float)) - base
    if waist:
        sol = geom.inverse_waist('right', c, standoff=radius, other_xyz=ped, other_standoff=0.0)
        if not sol.ik.reachable:
            return False, 'suction: ' + sol.ik.reason
        if not sol.other.reachable:
            return False, 'shear: ' + sol.other.reason
        return True, ''
    right = geom.inverse('right', c, standoff=radius)
    if not right.reachable:
        return False, 'suction: ' + right.reason
    left = geom.inverse('left', ped, standoff=0.0, other_arm_joints=right.joints)
    if not left.reachable:
        return False, 'shear: ' + left.reason
    return True, ''


def mark_reachability(scenario, geom):
    """Recompute every fruit's `reachable` flag (False for fruit in view of no picking point)."""
    for f in scenario.fruits:
        if f.picking_point < 0:
            f.reachable = False
        else:
            f.reachable = reachability(geom, f.position, f.radius,
                                       scenario.track.picking_points[f.picking_point],
                                       f.peduncle)[0]
    return scenario


def stereo_eyes(geom, cart_y):
    """Poses (4x4 in map) of the left and right stereo optical frames at a picking point."""
    poses = geom.frame_transforms({'cart_joint': cart_y})
    return poses['stereo_left_optical'], poses['stereo_right_optical']


def fully_in_view(camera, eyes, position, radius, margin_px=4.0):
    """True if the fruit's projected disc lies inside every camera image of `eyes`."""
    for T in eyes:
        pc = camera_model.to_camera(T, position)[0]
        if pc[2] <= radius + 0.05:
            return False
        u, v = camera.project(pc)[0]
        rp = camera.fx * radius / math.sqrt(max(pc[2] ** 2 - radius ** 2, 1e-9)) + margin_px
        if u - rp < 0 or u + rp > camera.width - 1 or v - rp < 0 or v + rp > camera.height - 1:
            return False
    return True
