"""Goal validation and monitors of the motion servers (motion_pkg.motion_goals)."""

import math
import os
import sys

import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from motion_pkg import motion_goals as mg  # noqa: E402
from motion_pkg.modbus_map import RegisterMap, split_int32  # noqa: E402

MAP = RegisterMap.from_file(os.path.join(HERE, '..', 'config', 'register_map.yaml'))
with open(os.path.join(HERE, '..', '..', 'harvest_description', 'config', 'robot.yaml')) as _f:
    LIMITS = mg.limits_from_robot_config(yaml.safe_load(_f))
NAN = float('nan')


def state(axes=None, io=0, shear=0):
    """ControllerState with {index: (position, status, fault)} for some axes."""
    regs = [0] * 80
    regs[0:7] = [0x4843, 1, 8, 0, 0, io, shear]
    for index, (pos, status, fault) in (axes or {}).items():
        base = 16 + 8 * index
        regs[base:base + 6] = split_int32(MAP.axes[index].to_counts(pos)) + [0, 0, status, fault]
    return MAP.decode_poll(regs)


ENABLED, MOVING, IN_POS, FAULT = 1, 2, 4, 8


def test_limits_from_robot_yaml():
    assert LIMITS['left_lift'].maximum == 0.30 and LIMITS['left_lift'].linear
    assert LIMITS['waist'].speed == pytest.approx(math.radians(30.0), abs=1e-5)
    assert not LIMITS['right_boom'].linear
    assert mg.arm_axes(False) == ['right_lift', 'right_boom', 'right_forearm']
    assert mg.arm_axes(True) == ['left_lift', 'left_boom', 'left_forearm']


def test_valid_goal_and_speed_limits():
    names, targets, speeds = mg.validate_arm_goal([0.1, 0.5, -0.5], [0.05, 0.0, 9.0], True,
                                                  LIMITS)
    assert names == mg.arm_axes(True) and targets == [0.1, 0.5, -0.5]
    assert speeds == [0.05, LIMITS['left_boom'].speed, LIMITS['left_forearm'].speed]


@pytest.mark.parametrize('positions,velocities,words', [
    ([0.1, NAN, 0.0], [], 'NaN'),
    ([0.1, float('inf'), 0.0], [], 'NaN or infinity'),
    ([0.1, 0.2], [], 'needs 3 values'),
    ([0.1, 0.2, 0.3, 0.4], [], 'needs 3 values'),
    ([0.31, 0.0, 0.0], [], 'right_lift target 310.0 mm is beyond the joint limits'),
    ([0.1, -2.7, 0.0], [], 'right_boom target -154.70 deg'),
    ([0.1, 0.0, 0.0], [1.0], 'empty or hold 3'),
    ([0.1, 0.0, 0.0], [0.1, NAN, 0.1], 'finite and >= 0'),
    ([0.1, 0.0, 0.0], [0.1, -0.1, 0.1], 'finite and >= 0'),
])
def test_invalid_goals(positions, velocities, words):
    with pytest.raises(mg.GoalError) as err:
        mg.validate_arm_goal(positions, velocities, False, LIMITS)
    assert words in str(err.value)


def test_move_duration():
    assert mg.move_duration(3.0, 0.2, 0.6) == pytest.approx(15.0 + 1.0 / 3.0)
    assert mg.move_duration(-0.1, 1.0, 1.0) == pytest.approx(2.0 * math.sqrt(0.1))
    assert mg.move_duration(0.0, 1.0, 1.0) == 0.0


def monitor(targets=(0.2, 1.0), starts=(0.0, 0.0), deadline=100.0):
    return mg.AxesMoveMonitor([2, 3], ['right_lift', 'right_boom'], targets, starts,
                              [0.001, math.radians(0.2)], 5, deadline, MAP.fault_text,
                              [LIMITS['right_lift'].unit, LIMITS['right_boom'].unit])


def test_move_monitor_progress_and_success():
    m = monitor()
    stale = state({2: (0.0, ENABLED | IN_POS, 0), 3: (0.0, ENABLED | IN_POS, 0)})
    assert m.update(4, stale, 1.0) is None                   # taken before the command
    assert m.update(5, state({2: (0.1, ENABLED | MOVING, 0), 3: (0.9, ENABLED | MOVING, 0)}),
                    1.0) is None
    assert m.percent == 50
    out = m.update(6, state({2: (0.2, ENABLED | IN_POS, 0), 3: (1.0, ENABLED | IN_POS, 0)}), 2.0)
    assert out.success and out.code == mg.SUCCESS and m.percent == 100


def test_move_monitor_failures():
    m = monitor()
    out = m.update(5, state({2: (0.1, MOVING | FAULT, 3), 3: (0.5, ENABLED | MOVING, 0)}), 1.0)
    assert out.code == mg.DRIVE_FAULT
    assert out.text == 'drive fault on right_lift: motor over-current (code 3)'
    m = monitor()
    out = m.update(5, state({2: (0.2, ENABLED, 0), 3: (0.5, ENABLED, 0)}), 1.0)
    assert out.code == mg.HALTED and 'right_boom stopped 28.65 deg from its target' in out.text
    m = monitor(deadline=3.0)
    out = m.update(9, state({2: (0.1, ENABLED | MOVING, 0), 3: (0.5, ENABLED | MOVING, 0)}), 3.5)
    assert out.code == mg.TIMEOUT and 'deadline' in out.text


def test_end_effector_monitors():
    m = mg.SuctionOnMonitor(3, 10.0, 2.0)
    assert m.update(3, state(io=0b01), 9.0) is None
    assert m.update(4, state(io=0b11), 9.5).success
    assert 'no vacuum within 2.00 s' in mg.SuctionOnMonitor(3, 10.0, 2.0).update(
        3, state(io=0b01), 10.5).text
    m = mg.SuctionOffMonitor(3, 10.0)
    assert m.update(3, state(io=0b01), 1.0) is None and m.update(4, state(io=0), 1.0).success
    m = mg.ShearMonitor(3, 10.0, 65535, 2.0)
    assert m.update(3, state(io=0b100, shear=65535), 1.0) is None
    assert m.update(4, state(io=0b1100, shear=0), 1.0).success      # wrapped counter


def test_status_summary():
    ok = {i: (0.0, ENABLED | IN_POS, 0) for i in range(8)}
    assert mg.status_summary(True, '', state(ok), MAP, 'h:1')[0] == 0
    bad = dict(ok)
    bad[6] = (0.0, FAULT, 4)
    level, text = mg.status_summary(True, '', state(bad), MAP, 'h:1')
    assert level == 2 and text == 'drive fault: left_boom: encoder signal lost (code 4)'
    off = dict(ok)
    off[0] = (0.0, IN_POS, 0)
    assert mg.status_summary(True, '', state(off), MAP, 'h:1') == (1, 'axes not enabled: cart')
    level, text = mg.status_summary(False, 'refused', None, MAP, 'h:1')
    assert level == 2 and 'no connection to the motion controller at h:1: refused' == text
    level, text = mg.status_summary(True, '', state(ok), MAP, 'h:1', 'exception 6')
    assert level == 2 and text == 'motion controller at h:1 answers with errors: exception 6'
