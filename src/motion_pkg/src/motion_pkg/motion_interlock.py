"""The cart interlock of ``motion_server`` (pure logic, no ROS).

The cart moves only with both arms stowed over it, and no arm moves while the cart does: an arm
reaching into the plant row while the cart drives along it sweeps through the plants (and the
other way round). The executive parks the arms before every ``move_base`` goal (PARK_ARMS, the
last fruit of a point); the interlock refuses what does not, a manual move from the dashboard
included.

An arm is stowed when its whole planar chain, the boom axis, the elbow and the tool centre (the
links between them are straight, so their ends bound them), lies at most ``max_x`` ahead of the
waist axis along base_link x, which points to the plant row, at the waist's present angle. The
arms' park poses are at most 0.10 m ahead (the boom axes themselves): the cutting hand home
(tool behind its arm base), the suction arm over the collection box. In the simulated plant
factory's scenarios an arm at a fruit (its suction, approach or standby pose) is 0.27 m or more
ahead and the nearest leaves begin 0.24 m ahead: the default limit is 0.20 m.
"""

import math

from motion_pkg.motion_arm_goals import ARMS

#: the points of an arm's chain, in ForwardKinematics.arm_points order
POINT_NAMES = ('boom axis', 'elbow', 'tool')


class CartInterlock(object):
    """Whether the arms are stowed, from the axes' positions (``geometry``: a
    kinematics_geometry.ForwardKinematics; ``max_x``: metres ahead of the waist axis)."""

    def __init__(self, geometry, max_x):
        max_x = float(max_x)
        if not math.isfinite(max_x):
            raise ValueError('stowed_max_x must be a finite distance (m), got %r' % (max_x,))
        self.geometry = geometry
        self.max_x = max_x

    def furthest(self, arm, lift, boom, forearm, waist=0.0):
        """(x, point name) of the arm's point furthest ahead toward the plant row."""
        points = self.geometry.arm_points(arm, lift, boom, forearm, waist)
        x, name = max((float(p[0]), n) for p, n in zip(points, POINT_NAMES))
        return x, name

    def arms_out(self, joints, waist=0.0):
        """The texts of the arms that are not stowed ([] when both are). ``joints``: {arm:
        (lift, boom, forearm)}; an arm whose joints are missing or not finite counts as out
        (where it is cannot be told)."""
        out = []
        if not math.isfinite(waist):
            return ['the waist angle is not known (%r)' % (waist,)]
        for arm in sorted(ARMS):
            values = joints.get(arm)
            if values is None or len(values) != 3 or \
                    not all(math.isfinite(v) for v in values):
                out.append('%s arm: joints not known (%r)' % (arm, values))
                continue
            x, name = self.furthest(arm, *values, waist=waist)
            if x > self.max_x:
                out.append('%s arm: %s %.2f m ahead of the waist axis' % (arm, name, x))
        return out

    def move_base_refusal(self, joints, waist, moving_arms):
        """Why a move_base goal is refused now ('' when the cart may move): an arm goal is
        running (``moving_arms``, arm names) or an arm is not stowed."""
        if moving_arms:
            return ('the cart does not move while an arm does (move_robot goal of the %s arm '
                    'running)' % ' and '.join(sorted(moving_arms)))
        out = self.arms_out(joints, waist)
        if out:
            return ('the cart does not move with an arm out (stowed: at most %.2f m ahead of '
                    'the waist axis): %s; park the arms first' % (self.max_x, '; '.join(out)))
        return ''


def move_robot_refusal(cart_moving):
    """Why a move_robot goal is refused now ('' when the arms may move): the cart is moving."""
    if cart_moving:
        return 'no arm moves while the cart does (a move_base goal is running)'
    return ''
