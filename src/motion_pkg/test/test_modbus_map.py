"""Register map codec of the motion driver (motion_pkg.modbus_map)."""

import math
import os
import sys

import pytest
from hypothesis import given, settings, strategies as st

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from motion_pkg.modbus_map import (RegisterMap, join_int32, join_uint32,  # noqa: E402
                                   parse_serial_number, split_int32, split_uint32)

MAP = RegisterMap.from_file(os.path.join(HERE, '..', 'config', 'register_map.yaml'))


@settings(max_examples=300, deadline=None)
@given(st.integers(-2 ** 31, 2 ** 31 - 1))
def test_int32_round_trip(value):
    words = split_int32(value)
    assert all(0 <= w <= 0xFFFF for w in words)
    assert join_int32(*words) == value


def test_int32_word_order():
    assert split_int32(1) == [0, 1]
    assert split_int32(-1) == [0xFFFF, 0xFFFF]
    assert split_int32(0x12345678) == [0x1234, 0x5678]
    with pytest.raises(ValueError):
        split_int32(2 ** 31)


def test_layout():
    assert MAP.axis_names == ['cart', 'waist', 'right_lift', 'right_boom', 'right_forearm',
                              'left_lift', 'left_boom', 'left_forearm']
    assert MAP.joint_names[0] == 'cart_joint' and MAP.joint_names[-1] == 'left_forearm_joint'
    assert MAP.poll_span() == (0, 80)
    assert MAP.feedback_address(3, 'status_word') == 16 + 24 + 4
    assert MAP.command_address(7, 'control_word') == 100 + 70 + 6


def test_scaling():
    lift = MAP.axis('right_lift')
    boom = MAP.axis('right_boom')
    assert lift.to_counts(0.25) == 25000             # 0.01 mm
    assert boom.to_counts(math.radians(90.0)) == 90000  # 0.001 deg
    assert boom.to_si(-45000) == pytest.approx(math.radians(-45.0))
    with pytest.raises(ValueError):
        lift.to_counts(1e6)


def test_encode_move():
    address, block = MAP.encode_move(2, 0.2, 0.05, 0.3)
    assert address == 120
    assert block == split_int32(20000) + split_int32(5000) + split_int32(30000) + [0b11]
    with pytest.raises(ValueError):
        MAP.encode_move(2, 0.2, -1.0)


def test_decode_poll():
    regs = [0] * 80
    regs[0:7] = [0x4843, 1, 8, 77, 0, 0b0011, 5]
    base = 16 + 8 * 3                                   # right_boom
    regs[base:base + 6] = split_int32(-30000) + split_int32(1000) + [0b1011, 3]
    state = MAP.decode_poll(regs)
    assert state.heartbeat == 77 and state.shear_count == 5
    assert state.suction_valve and state.vacuum_ok and not state.shear_busy
    boom = state.axes[3]
    assert boom.position == pytest.approx(math.radians(-30.0))
    assert boom.velocity == pytest.approx(math.radians(1.0))
    assert boom.enabled and boom.moving and boom.fault and not boom.in_position
    assert boom.fault_code == 3
    assert MAP.fault_text(3) == 'motor over-current'
    assert 'unknown' in MAP.fault_text(99)
    with pytest.raises(ValueError):
        MAP.decode_poll(regs[:40])


def test_identity_check():
    assert MAP.check_identity([0x4843, 1, 8]) is None
    assert 'identity' in MAP.check_identity([0x1234, 1, 8])
    assert 'version' in MAP.check_identity([0x4843, 2, 8])
    assert 'axes' in MAP.check_identity([0x4843, 1, 6])


def identity_block(serial_number, ident=0x4843, version=1, axes=8):
    regs = [0] * MAP.identity_span()[1]
    regs[0:3] = [ident, version, axes]
    regs[7:9] = split_uint32(serial_number)
    return regs


def test_identity_span_covers_the_serial_number():
    assert MAP.system['serial_number'] == 7
    assert MAP.identity_span() == (0, 9)
    start, count = MAP.poll_span()
    assert (start, count) == (0, 80)            # the poll is unchanged by the identity block


def test_uint32_words():
    assert split_uint32(0xC0FFEE01) == [0xC0FF, 0xEE01]
    assert join_uint32(0xC0FF, 0xEE01) == 0xC0FFEE01
    assert join_uint32(*split_uint32(0xFFFFFFFF)) == 0xFFFFFFFF
    with pytest.raises(ValueError):
        split_uint32(-1)
    with pytest.raises(ValueError):
        split_uint32(2 ** 32)


def test_serial_number_check():
    assert MAP.check_identity(identity_block(4711), 4711) is None
    assert MAP.check_identity(identity_block(4711)) is None             # None: any serial
    problem = MAP.check_identity(identity_block(4712), 4711)
    assert problem == 'controller serial number 4712, expected 4711'
    problem = MAP.check_identity(identity_block(0xC0FFEE01), 0xC0FFEE02)   # both words count
    assert 'serial number 3237998081, expected 3237998082' in problem
    no_block = [0x4843, 1, 8] + [0] * 6          # a controller without the register reads 0
    assert 'no serial number' in MAP.check_identity(no_block, 4711)
    # the map's own checks come first: a foreign device is named as such
    assert 'identity' in MAP.check_identity(identity_block(4711, ident=0x1234), 4711)
    with pytest.raises(ValueError):
        MAP.check_identity([0x4843, 1, 8], 4711)   # too short to hold the serial number


@pytest.mark.parametrize('value,number', [(1, 1), ('4711', 4711), (' 0x10 ', 16),
                                          ('4294967295', 0xFFFFFFFF)])
def test_parse_serial_number(value, number):
    assert parse_serial_number(value) == number


@pytest.mark.parametrize('value', [0, -3, '0', 2 ** 32, 'abc', '', None, True, 1.5])
def test_bad_serial_numbers(value):
    with pytest.raises(ValueError):
        parse_serial_number(value)
