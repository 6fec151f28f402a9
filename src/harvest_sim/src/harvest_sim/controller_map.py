"""Register map of the simulated multi-axis motion controller (its "firmware" constants).

Pure data, no ROS. docs/register_map.md documents the same map for humans and
motion_pkg/config/register_map.yaml describes it for the driver; test_controller_map.py checks
that all three agree. All addresses are 0-based PDU addresses (mbpoll: use -0, or add 1).

Numbers: 32-bit values are signed two's complement in two consecutive registers, high word first
(mbpoll -B). Linear axes count in 0.01 mm (100000 counts per metre), rotary axes in 0.001 degree
(1000 counts per degree); speeds and accelerations use the same counts per second (squared).
"""

import math
# the one codec of the wire format, shared with the driver
from motion_pkg.modbus_map import (join_int32, join_uint32, parse_serial_number,  # noqa: F401
                                   split_int32, split_uint32)

MAP_VERSION = 1
IDENTITY = 0x4843             # "HC": harvest controller
DEFAULT_SERIAL_NUMBER = 1     # sim_controller ~serial_number, motion_server ~controller_serial

# --- holding registers, system block -----------------------------------------------------
REG_IDENTITY = 0              # RO  constant IDENTITY
REG_MAP_VERSION = 1           # RO  MAP_VERSION
REG_AXIS_COUNT = 2            # RO  number of axes (8)
REG_HEARTBEAT = 3             # RO  controller time in 10 ms ticks, modulo 65536
REG_SYSTEM_CONTROL = 4        # RW  pulse bits below, read back as 0
REG_IO_STATUS = 5             # RO  mirror of coils and discrete inputs, bits below
REG_SHEAR_COUNT = 6           # RO  completed shear strokes (blade closures), modulo 65536
REG_SERIAL_NUMBER = 7         # RO  uint32 (7-8, high word first): this controller's serial number
SYSTEM_BLOCK_SIZE = 16

SYS_ENABLE_ALL = 0            # set the enable bit of every axis
SYS_HALT_ALL = 1              # halt every axis (decelerate to rest)
SYS_CLEAR_FAULTS = 2          # clear the fault of every axis
SYS_DISABLE_ALL = 3           # clear the enable bit of every axis (axes stop first)

IO_SUCTION_VALVE = 0          # valve open
IO_VACUUM_OK = 1              # vacuum sensor
IO_SHEAR_BUSY = 2             # a shear stroke is running
IO_SHEAR_CLOSED = 3           # shear-closed sensor

# --- holding registers, axis feedback (read-only): FEEDBACK_BASE + FEEDBACK_STRIDE * axis ---
FEEDBACK_BASE = 16
FEEDBACK_STRIDE = 8
FB_ACTUAL_POSITION = 0        # int32, 2 registers
FB_ACTUAL_VELOCITY = 2        # int32, 2 registers
FB_STATUS_WORD = 4
FB_FAULT_CODE = 5

# --- holding registers, axis command (read/write): COMMAND_BASE + COMMAND_STRIDE * axis ------
COMMAND_BASE = 100
COMMAND_STRIDE = 10
CMD_TARGET_POSITION = 0       # int32
CMD_SPEED = 2                 # int32 >= 0; 0 = axis maximum; above the maximum is clipped
CMD_ACCELERATION = 4          # int32 >= 0; 0 = axis maximum; above the maximum is clipped
CMD_CONTROL_WORD = 6

CW_ENABLE = 0                 # level: drive enabled while set (and no fault)
CW_START = 1                  # pulse: start a move to the target position
CW_HALT = 2                   # pulse: decelerate to rest
CW_CLEAR_FAULT = 3            # pulse: clear the fault
CW_PULSE_MASK = (1 << CW_START) | (1 << CW_HALT) | (1 << CW_CLEAR_FAULT)

SW_ENABLED = 0
SW_MOVING = 1
SW_IN_POSITION = 2
SW_FAULT = 3

HOLDING_REGISTER_COUNT = 200  # addresses 0..199 exist; beyond -> Modbus exception 2

# --- coils and discrete inputs -------------------------------------------------------------
COIL_SUCTION_VALVE = 0        # 1 = valve open
COIL_SHEAR = 1                # write 1: one stroke; reads 1 while the stroke runs
COIL_COUNT = 8
DI_VACUUM_OK = 0
DI_SHEAR_CLOSED = 1
DI_SUCTION_VALVE = 2          # valve position feedback
DI_COUNT = 8

# --- fault codes (FB_FAULT_CODE) ----------------------------------------------------------
FAULT_NONE = 0
FAULT_TARGET_OUT_OF_RANGE = 1
FAULT_FOLLOWING_ERROR = 2
FAULT_OVER_CURRENT = 3
FAULT_ENCODER = 4
FAULT_OVER_TEMPERATURE = 5
FAULT_NOT_ENABLED = 6
FAULT_BAD_PROFILE = 7
FAULT_NAMES = {
    FAULT_NONE: 'none',
    FAULT_TARGET_OUT_OF_RANGE: 'target_out_of_range',
    FAULT_FOLLOWING_ERROR: 'following_error',
    FAULT_OVER_CURRENT: 'over_current',
    FAULT_ENCODER: 'encoder',
    FAULT_OVER_TEMPERATURE: 'over_temperature',
    FAULT_NOT_ENABLED: 'not_enabled',
    FAULT_BAD_PROFILE: 'bad_profile',
}

# --- axes and scaling ---------------------------------------------------------------------
LINEAR_COUNTS_PER_UNIT = 100000.0                 # 0.01 mm per count
ROTARY_COUNTS_PER_UNIT = 1000.0 * 180.0 / math.pi  # 0.001 degree per count
LINEAR_AXES = ('cart', 'right_lift', 'left_lift')
IN_POSITION_WINDOW = 10       # counts: 0.1 mm or 0.01 degree


def counts_per_unit(axis_name):
    """Counts per metre (linear axes) or per radian (rotary axes)."""
    return LINEAR_COUNTS_PER_UNIT if axis_name in LINEAR_AXES else ROTARY_COUNTS_PER_UNIT


def feedback_address(axis, offset):
    return FEEDBACK_BASE + FEEDBACK_STRIDE * axis + offset


def command_address(axis, offset):
    return COMMAND_BASE + COMMAND_STRIDE * axis + offset


def clamp_int32(value):
    return int(max(-2 ** 31, min(2 ** 31 - 1, value)))
