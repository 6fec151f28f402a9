"""The register map agrees in three places: the simulator's constants (controller_map), the
document docs/register_map.md and the driver's motion_pkg/config/register_map.yaml."""

import math
import os
import re
import sys

import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from harvest_sim import controller_map as cm  # noqa: E402

DOC = os.path.join(HERE, '..', 'docs', 'register_map.md')
MAP_YAML = os.path.join(HERE, '..', '..', 'motion_pkg', 'config', 'register_map.yaml')
ROBOT_YAML = os.path.join(HERE, '..', '..', 'harvest_description', 'config', 'robot.yaml')


def doc_tables():
    """{heading: [row cells]} of every markdown table in the document."""
    tables, heading = {}, None
    with open(DOC) as f:
        for line in f:
            line = line.strip()
            if line.startswith('#'):
                heading = line.lstrip('#').strip()
            elif line.startswith('|') and not re.match(r'^\|[-| ]+\|$', line):
                cells = [c.strip().strip('`') for c in line.strip('|').split('|')]
                tables.setdefault(heading, []).append(cells)
    return {h: rows[1:] for h, rows in tables.items()}     # drop header rows


@pytest.fixture(scope='module')
def doc():
    return doc_tables()


@pytest.fixture(scope='module')
def rmap():
    with open(MAP_YAML) as f:
        return yaml.safe_load(f)['register_map']


def bits_of(rows):
    return {r[1]: int(r[0]) for r in rows}


def test_blocks(doc, rmap):
    blocks = {r[0]: r for r in doc['Blocks']}
    assert int(blocks['feedback'][2]) == cm.FEEDBACK_BASE == rmap['feedback']['base']
    assert int(blocks['feedback'][3]) == cm.FEEDBACK_STRIDE == rmap['feedback']['stride']
    assert int(blocks['command'][2]) == cm.COMMAND_BASE == rmap['command']['base']
    assert int(blocks['command'][3]) == cm.COMMAND_STRIDE == rmap['command']['stride']
    assert int(blocks['system'][4]) == cm.SYSTEM_BLOCK_SIZE
    assert rmap['identity'] == cm.IDENTITY and rmap['version'] == cm.MAP_VERSION


def test_system_block(doc, rmap):
    rows = {r[1]: r for r in doc['System block']}
    assert set(rows) == set(rmap['system'])
    for name, row in rows.items():
        assert int(row[0]) == rmap['system'][name]['address'] == getattr(cm, 'REG_' + name.upper())
        assert row[2] == rmap['system'][name]['type']
        assert row[3] == rmap['system'][name]['access'].upper()


def test_axis_registers(doc, rmap):
    for heading, block, prefix in (('Axis feedback', 'feedback', 'FB_'),
                                   ('Axis command', 'command', 'CMD_')):
        rows = {r[1]: r for r in doc[heading]}
        regs = rmap[block]['registers']
        assert set(rows) == set(regs)
        for name, row in rows.items():
            assert int(row[0]) == regs[name]['offset'] == getattr(cm, prefix + name.upper())
            assert row[2] == regs[name]['type']
            assert row[3] == regs[name]['access'].upper()


@pytest.mark.parametrize('heading,key,prefix', [
    ('System control bits', 'system_control_bits', 'SYS_'),
    ('I/O status bits', 'io_status_bits', 'IO_'),
    ('Status word bits', 'status_word_bits', 'SW_'),
    ('Control word bits', 'control_word_bits', 'CW_'),
])
def test_bits(doc, rmap, heading, key, prefix):
    bits = bits_of(doc[heading])
    assert bits == rmap[key]
    for name, bit in bits.items():
        assert getattr(cm, prefix + name.upper()) == bit


def test_coils_and_inputs(doc, rmap):
    coils = {r[1]: int(r[0]) for r in doc['Coils']}
    inputs = {r[1]: int(r[0]) for r in doc['Discrete inputs']}
    assert coils == rmap['coils'] == {'suction_valve': cm.COIL_SUCTION_VALVE,
                                      'shear': cm.COIL_SHEAR}
    assert inputs == rmap['discrete_inputs']
    for name, address in inputs.items():
        assert getattr(cm, 'DI_' + name.upper()) == address


def test_axes_and_scaling(doc, rmap):
    with open(ROBOT_YAML) as f:
        robot_axes = yaml.safe_load(f)['axes']
    rows = doc['Axes']
    assert [r[1] for r in rows] == robot_axes == [a['name'] for a in rmap['axes']]
    for row, axis in zip(rows, rmap['axes']):
        assert int(row[0]) == rows.index(row)
        assert row[2] == axis['joint'] == axis['name'] + '_joint'
        assert row[3] == axis['scaling']
        assert cm.counts_per_unit(axis['name']) == pytest.approx(rmap['scaling'][axis['scaling']])
    assert rmap['scaling']['linear'] == cm.LINEAR_COUNTS_PER_UNIT == 1e5
    assert rmap['scaling']['rotary'] == pytest.approx(1000.0 * 180.0 / math.pi)


def test_fault_codes(doc, rmap):
    rows = {int(r[0]): r for r in doc['Fault codes']}
    assert set(rows) == set(rmap['fault_codes']) == set(cm.FAULT_NAMES)
    for code, row in rows.items():
        assert row[1] == rmap['fault_codes'][code]['name'] == cm.FAULT_NAMES[code]
        assert row[2] == rmap['fault_codes'][code]['text']
