"""The simulated world and cameras with the waist turned (scenario waist_reach), no master."""

import math
import os

import numpy as np
import pytest

from sim_fixtures import GEOM, SCENARIOS, scn

from harvest_sim import camera_model, render, world as w

SCENARIO = scn.load_scenario(os.path.join(SCENARIOS, 'waist_reach.yaml'))


def waist_only():
    """(fruit, cart y) of every fruit of waist_reach that only a turn of the waist reaches."""
    out = []
    for f in SCENARIO.fruits:
        y = SCENARIO.track.picking_points[f.picking_point]
        if f.reachable and not scn.reachability(GEOM, f.position, f.radius, y, f.peduncle,
                                                waist=False)[0]:
            out.append((f, y))
    return out


def joints_of(arm, q):
    return dict(zip(['%s_%s_joint' % (arm, j) for j in ('lift', 'boom', 'forearm')], q))


@pytest.mark.parametrize('index', range(4))
def test_waist_fruit_sealed_and_harvested_with_the_waist_turned(index):
    fruit, y = waist_only()[index]
    base = np.array([0.0, y, 0.0])
    sol = GEOM.inverse_waist('right', fruit.position - base, fruit.radius,
                             other_xyz=fruit.peduncle - base)
    assert sol.moved and sol.ik.reachable and sol.other.reachable
    world = w.World(SCENARIO, GEOM)
    joints = {'cart_joint': y, 'waist_joint': sol.waist}
    joints.update(joints_of('left', kin_home('left')))
    joints.update(joints_of('right', sol.ik.joints))
    world.set_joints(joints)
    world.set_valve(True)
    held = world.held
    assert held is not None and held.id == fruit.id
    # the cutting hand at the peduncle (standoff 0, where the visual servo ends), same waist
    world.set_joints(joints_of('left', sol.other.joints))
    events = world.shear_cut()
    assert held.state == w.HARVESTED, events
    # the same joints at waist 0 put the suction cup nowhere near this fruit
    world0 = w.World(SCENARIO, GEOM)
    joints['waist_joint'] = 0.0
    world0.set_joints(joints)
    tcp = world0.tcp(w.SUCTION_TCP)
    assert abs(np.linalg.norm(tcp - fruit.position) - fruit.radius) > 0.03


def kin_home(arm):
    from motion_pkg.kinematics import HOME_JOINTS
    return HOME_JOINTS[arm]


def test_stereo_head_turns_with_the_waist_and_keeps_the_fruit_in_view():
    """The stereo head rides on the waist: with the waist turned toward a fruit beside the fixed
    workspace the fruit is still in both images, drawn where the turned head projects it."""
    fruit, y = waist_only()[0]
    base = np.array([0.0, y, 0.0])
    turn = GEOM.inverse_waist('right', fruit.position - base, fruit.radius,
                              other_xyz=fruit.peduncle - base).waist
    cam = camera_model.stereo_camera()
    straight = render.camera_poses(GEOM, {'cart_joint': y})
    turned = render.camera_poses(GEOM, {'cart_joint': y, 'waist_joint': turn})
    eye = 'stereo_right_optical'
    # the optical axis turned by the waist angle about z
    a, b = straight[eye][:3, 2], turned[eye][:3, 2]
    assert math.atan2(a[0] * b[1] - a[1] * b[0], a.dot(b)) == pytest.approx(turn, abs=1e-9)
    eyes = (turned['stereo_left_optical'], turned['stereo_right_optical'])
    assert scn.fully_in_view(cam, eyes, fruit.position, fruit.radius)
    s = scn.Scenario('one', scn.Track([y]), scn.Lighting(),
                     [scn.Fruit('f', fruit.position, fruit.radius, 0.9, picking_point=0)], seed=1)
    _, labels = render.Renderer(s).render(cam, turned[eye], render.fruits_from_scenario(s),
                                          ('x', 0), labels=True)
    ys, xs = np.nonzero(labels == 1)
    assert xs.size > 500
    expect = cam.project(camera_model.to_camera(turned[eye], fruit.position)[0])[0]
    assert np.linalg.norm([xs.mean() - expect[0], ys.mean() - expect[1]]) < 3.0
