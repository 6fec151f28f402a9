"""Register-level behaviour of the simulated controller (harvest_sim.controller_model)."""

import math
import os
import sys

import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from harvest_sim import controller_map as cm  # noqa: E402
from harvest_sim.controller_model import ControllerModel, axes_from_robot_config  # noqa: E402

ROBOT_YAML = os.path.join(HERE, '..', '..', 'harvest_description', 'config', 'robot.yaml')
with open(ROBOT_YAML) as _f:
    ROBOT = yaml.safe_load(_f)

CART, WAIST, R_LIFT, R_BOOM = 0, 1, 2, 3


@pytest.fixture
def model():
    return ControllerModel(axes_from_robot_config(ROBOT), 0.5, 0.3, 0.2, 0.0)


def feedback(m, axis, t):
    regs = m.read_holding(cm.feedback_address(axis, 0), cm.FEEDBACK_STRIDE, t)
    return (cm.join_int32(regs[0], regs[1]), cm.join_int32(regs[2], regs[3]), regs[4], regs[5])


def move(m, axis, counts, t, speed=0, accel=0, control=(1 << cm.CW_ENABLE) | (1 << cm.CW_START)):
    block = cm.split_int32(counts) + cm.split_int32(speed) + cm.split_int32(accel) + [control]
    m.write_holding(cm.command_address(axis, 0), block, t)


def bit(word, n):
    return bool(word & (1 << n))


def test_axes_follow_robot_yaml(model):
    assert model.names == ROBOT['axes']
    lift = model.axes[R_LIFT].cfg
    assert (lift.minimum, lift.maximum, lift.max_speed) == (0.0, 0.30, 0.10)
    assert model.axes[R_BOOM].cfg.counts == pytest.approx(1000 * 180 / math.pi)


def test_system_block(model):
    regs = model.read_holding(0, cm.SYSTEM_BLOCK_SIZE, 12.345)
    assert regs[:4] == [cm.IDENTITY, cm.MAP_VERSION, 8, 1234]
    assert regs[cm.REG_SERIAL_NUMBER:cm.REG_SERIAL_NUMBER + 2] == [0, cm.DEFAULT_SERIAL_NUMBER]
    assert regs[cm.REG_SERIAL_NUMBER + 2:] == [0] * (cm.SYSTEM_BLOCK_SIZE - 9)   # reserved


def test_serial_number_registers():
    m = ControllerModel(axes_from_robot_config(ROBOT), serial_number='0xC0FFEE01')
    regs = m.read_holding(cm.REG_SERIAL_NUMBER, 2, 0.0)
    assert regs == [0xC0FF, 0xEE01] and cm.join_uint32(*regs) == m.serial_number == 0xC0FFEE01
    assert not m.valid('h', cm.REG_SERIAL_NUMBER, 2, write=True)        # read-only
    for bad in (0, 2 ** 32, 'x'):
        with pytest.raises(ValueError):
            ControllerModel(axes_from_robot_config(ROBOT), serial_number=bad)


def test_int32_round_trip():
    for v in (0, 1, -1, 2 ** 31 - 1, -2 ** 31, 123456, -654321):
        assert cm.join_int32(*cm.split_int32(v)) == v
    with pytest.raises(ValueError):
        cm.split_int32(2 ** 31)


def test_disabled_axis_refuses_moves(model):
    move(model, R_LIFT, 10000, 0.0, control=1 << cm.CW_START)
    pos, _, status, code = feedback(model, R_LIFT, 0.1)
    assert code == cm.FAULT_NOT_ENABLED and bit(status, cm.SW_FAULT)
    assert not bit(status, cm.SW_ENABLED) and pos == 0


def test_move_follows_trapezoid(model):
    model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_ENABLE_ALL], 0.0)
    move(model, R_LIFT, 20000, 1.0)                  # 0.2 m at 0.1 m/s, 0.3 m/s^2
    pos, vel, status, _ = feedback(model, R_LIFT, 1.5)
    assert bit(status, cm.SW_MOVING) and not bit(status, cm.SW_IN_POSITION)
    assert vel == pytest.approx(10000, abs=1)
    t_end = 1.0 + 0.2 / 0.1 + 0.1 / 0.3
    assert bit(feedback(model, R_LIFT, t_end - 0.01)[2], cm.SW_MOVING)
    pos, vel, status, _ = feedback(model, R_LIFT, t_end + 1e-6)
    assert (pos, vel) == (20000, 0)
    assert bit(status, cm.SW_IN_POSITION) and bit(status, cm.SW_ENABLED)
    assert model.read_holding(cm.command_address(R_LIFT, cm.CMD_CONTROL_WORD), 1, 5.0) == [1]


def test_speed_register_limits_and_clips(model):
    model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_ENABLE_ALL], 0.0)
    move(model, CART, 100000, 0.0, speed=10000)       # 1 m at 0.1 m/s
    assert feedback(model, CART, 5.0)[1] == 10000
    move(model, CART, 0, 20.0, speed=10 ** 8)          # clipped to 0.2 m/s
    assert feedback(model, CART, 25.0)[1] == -20000


def test_target_beyond_limit_faults_and_stops(model):
    model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_ENABLE_ALL], 0.0)
    move(model, R_BOOM, 100000, 0.0)                   # 100 deg, fine
    move(model, R_BOOM, 151000, 0.5)                   # 151 deg > 150 deg
    _, vel, status, code = feedback(model, R_BOOM, 0.5)
    assert code == cm.FAULT_TARGET_OUT_OF_RANGE
    assert bit(status, cm.SW_FAULT) and not bit(status, cm.SW_ENABLED)
    assert bit(status, cm.SW_MOVING)                   # decelerating
    _, vel, status, _ = feedback(model, R_BOOM, 2.0)
    assert vel == 0 and not bit(status, cm.SW_MOVING)
    move(model, R_BOOM, 0, 2.0)                        # refused while faulted
    assert not bit(feedback(model, R_BOOM, 2.1)[2], cm.SW_MOVING)
    model.write_holding(cm.command_address(R_BOOM, cm.CMD_CONTROL_WORD),
                        [(1 << cm.CW_CLEAR_FAULT) | (1 << cm.CW_ENABLE)], 3.0)
    assert feedback(model, R_BOOM, 3.0)[3] == 0
    move(model, R_BOOM, 0, 3.0)
    assert bit(feedback(model, R_BOOM, 3.1)[2], cm.SW_MOVING)


def test_negative_speed_is_a_bad_profile(model):
    model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_ENABLE_ALL], 0.0)
    move(model, WAIST, 1000, 0.0, speed=-5)
    assert feedback(model, WAIST, 0.0)[3] == cm.FAULT_BAD_PROFILE


def test_halt_decelerates_to_rest(model):
    model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_ENABLE_ALL], 0.0)
    move(model, CART, 500000, 0.0)
    model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_HALT_ALL], 2.0)   # at 0.2 m/s
    pos_halt = feedback(model, CART, 2.0)[0]
    assert bit(feedback(model, CART, 2.2)[2], cm.SW_MOVING)
    pos, vel, status, _ = feedback(model, CART, 2.0 + 0.2 / 0.6 + 1e-6)
    assert vel == 0 and not bit(status, cm.SW_IN_POSITION)
    assert pos - pos_halt == pytest.approx(0.2 ** 2 / 1.2 * 1e5, abs=2)


def test_new_target_while_moving_reverses_smoothly(model):
    model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_ENABLE_ALL], 0.0)
    move(model, R_LIFT, 30000, 0.0)
    move(model, R_LIFT, 0, 1.0)
    _, vel, _, _ = feedback(model, R_LIFT, 1.0)
    assert vel == 10000                                # no velocity jump
    pos, vel, status, _ = feedback(model, R_LIFT, 10.0)
    assert (pos, vel) == (0, 0) and bit(status, cm.SW_IN_POSITION)


def test_injected_fault(model):
    model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_ENABLE_ALL], 0.0)
    model.inject_axis_fault('right_boom', cm.FAULT_OVER_CURRENT, 1.0)
    assert feedback(model, R_BOOM, 1.0)[3] == cm.FAULT_OVER_CURRENT
    model.inject_axis_fault('0', cm.FAULT_ENCODER, 1.0)
    assert feedback(model, CART, 1.0)[3] == cm.FAULT_ENCODER
    with pytest.raises(ValueError):
        model.inject_axis_fault('elbow', 3, 1.0)
    model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_CLEAR_FAULTS], 2.0)
    assert feedback(model, R_BOOM, 2.0)[3] == 0 and bit(feedback(model, R_BOOM, 2.0)[2], 0)


def test_vacuum_needs_valve_seal_and_build_up(model):
    model.write_coils(cm.COIL_SUCTION_VALVE, [1], 1.0)
    assert model.read_discrete(0, 3, 5.0) == [0, 0, 1]           # no fruit under the cup
    model.set_sealed(True, 6.0)
    assert model.read_discrete(cm.DI_VACUUM_OK, 1, 6.49) == [0]
    assert model.read_discrete(cm.DI_VACUUM_OK, 1, 6.5) == [1]
    assert model.read_holding(cm.REG_IO_STATUS, 1, 6.5)[0] == 0b11
    model.write_coils(cm.COIL_SUCTION_VALVE, [0], 7.0)
    assert model.read_discrete(cm.DI_VACUUM_OK, 1, 7.0) == [0]
    events = model.pop_events(7.0)
    assert events == [('valve', 1.0, True), ('valve', 7.0, False)]
    # the closing let go of the fruit: the seal reported before it does not count for the next
    # opening (the world's release may come late), only one reported anew
    model.write_coils(cm.COIL_SUCTION_VALVE, [1], 8.0)
    assert model.read_discrete(cm.DI_VACUUM_OK, 1, 9.0) == [0]
    model.set_sealed(False, 9.05)                                   # the late release
    model.set_sealed(True, 9.1)                                     # sealed anew
    assert model.read_discrete(cm.DI_VACUUM_OK, 1, 9.5) == [0]
    assert model.read_discrete(cm.DI_VACUUM_OK, 1, 9.6) == [1]


def test_a_seal_reported_before_the_valve_opens_counts(model):
    # the cup put on a fruit first, then the valve opened
    model.set_sealed(True, 1.0)
    model.write_coils(cm.COIL_SUCTION_VALVE, [1], 2.0)
    assert model.read_discrete(cm.DI_VACUUM_OK, 1, 2.49) == [0]
    assert model.read_discrete(cm.DI_VACUUM_OK, 1, 2.5) == [1]


def test_shear_stroke(model):
    model.write_coils(cm.COIL_SHEAR, [1], 1.0)
    assert model.read_coils(0, 2, 1.1) == [0, 1]
    assert model.read_discrete(cm.DI_SHEAR_CLOSED, 1, 1.29) == [0]
    model.write_coils(cm.COIL_SHEAR, [1], 1.2)                     # ignored mid-stroke
    assert model.read_discrete(cm.DI_SHEAR_CLOSED, 1, 1.35) == [1]
    assert model.read_holding(cm.REG_SHEAR_COUNT, 1, 1.35) == [1]
    assert model.read_coils(cm.COIL_SHEAR, 1, 1.6) == [0]
    assert model.pop_events(2.0) == [('shear_cut', pytest.approx(1.3))]
    model.write_coils(cm.COIL_SHEAR, [1], 3.0)
    assert model.pop_events(10.0) == [('shear_cut', pytest.approx(3.3))]   # late poll
    assert model.read_holding(cm.REG_SHEAR_COUNT, 1, 10.0) == [2]


def test_address_validation(model):
    assert model.valid('h', 0, 80)
    assert not model.valid('h', 195, 10)
    assert model.valid('h', cm.REG_SYSTEM_CONTROL, 1, write=True)
    assert not model.valid('h', cm.REG_HEARTBEAT, 1, write=True)
    assert not model.valid('h', 16, 2, write=True)
    assert model.valid('h', 100, 80, write=True)
    assert not model.valid('h', 100, 81, write=True)
    assert not model.valid('d', 0, 1, write=True)
    assert not model.valid('c', 7, 2)


def test_joint_states_are_exact(model):
    model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_ENABLE_ALL], 0.0)
    move(model, R_BOOM, 10000, 0.0)
    positions, velocities = model.joint_states(100.0)
    assert positions[R_BOOM] == pytest.approx(math.radians(10.0))
    assert velocities == [0.0] * 8


def test_time_never_runs_backwards(model):
    model.update(5.0)
    assert model.read_holding(cm.REG_HEARTBEAT, 1, 1.0) == [500]


def test_busy_until_knows_when_everything_under_way_ends(model):
    assert model.busy_until(1.0) == 1.0                       # at rest
    move(model, CART, model.axes[CART].to_counts(0.5), 1.0)
    end = model.axes[CART].profile.end_time
    assert end > 1.5
    assert model.busy_until(1.2) == pytest.approx(end)        # known when the command comes
    assert model.busy_until(end + 0.1) == pytest.approx(end + 0.1)
    model.set_valve(True, 10.0)
    assert model.busy_until(10.0) == 10.0                     # an open valve alone does nothing
    model.set_sealed(True, 10.2)
    assert model.busy_until(10.2) == pytest.approx(10.7)      # vacuum builds up for 0.5 s
    model.start_shear(11.0)
    assert model.busy_until(11.0) == pytest.approx(11.5)      # 0.3 s stroke + 0.2 s hold
    assert model.busy_until(11.6) == pytest.approx(11.6)


def test_closure_pose_is_the_arm_when_the_closure_was_first_noticed(model):
    # the closure (t = 1.3) is first noticed by a read at 1.35; a move commanded after that
    # read must not change the pose the closure is judged with, even if the next regular
    # joint state comes much later
    model.write_holding(cm.REG_SYSTEM_CONTROL, [1 << cm.SYS_ENABLE_ALL], 0.0)
    model.write_coils(cm.COIL_SHEAR, [1], 1.0)
    assert model.pop_closure_pose() is None
    assert model.read_holding(cm.REG_SHEAR_COUNT, 1, 1.35) == [1]
    move(model, R_LIFT, 20000, 1.4)
    t, positions, velocities = model.pop_closure_pose()
    assert t == pytest.approx(1.35)
    assert positions[R_LIFT] == 0.0 and velocities[R_LIFT] == 0.0
    assert model.joint_states(2.0)[0][R_LIFT] > 0.0          # the arm has moved on since
    assert model.pop_events(2.0) == [('shear_cut', pytest.approx(1.3))]
    assert model.pop_closure_pose() is None                  # once per closure
