"""robot.yaml validator (harvest_description.robot_config): examples and hypothesis properties.

Every reader of robot.yaml relies on it (motion_pkg, harvest_sim, this package), so the
properties check that a bad value is refused naming exactly its field, in one line, and that
whatever the validator accepts gives only finite numbers to the readers (the URDF here).
"""

import copy
import math
import os
import sys

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(PKG, 'src'))

from harvest_description import robot_config as rc  # noqa: E402
from visualization_pkg.arm_geometry import ArmGeometry  # noqa: E402
from visualization_pkg.dashboard import manual_ops  # noqa: E402
from harvest_description.urdf_generator import build_urdf  # noqa: E402
from harvest_test_utils.config import with_value  # noqa: E402

DESCRIPTION = os.path.join(os.path.dirname(PKG), 'harvest_description')
ROBOT_YAML = os.path.join(DESCRIPTION, 'config', 'robot.yaml')
with open(ROBOT_YAML) as _f:
    ROBOT = yaml.safe_load(_f)

NON_FINITE = [float('nan'), float('inf'), float('-inf')]
PROPERTY = settings(deadline=None)          # no timing in these tests
OPTIONAL = {'robot.waist.height', 'robot.collection_box',
            'robot.collection_box.right_arm_joints', 'robot.arms.right.fruit_radius'}
LIMIT_PAIRS = ['robot.track', 'robot.waist', 'robot.joint_limits.lift',
               'robot.joint_limits.boom', 'robot.joint_limits.forearm']
POSITIVE = (['motion.%s.%s' % (s, k) for s in ('speed', 'acceleration') for k in rc.MOTION_KINDS]
            + ['robot.link_lengths.%s' % k for k in ('boom', 'forearm', 'tool')]
            + ['robot.stereo_head.baseline'])


def _walk(node, path, keys):
    if isinstance(node, dict):
        for key, value in node.items():
            child = '%s.%s' % (path, key) if path else key
            yield child, keys + (key,), value
            for item in _walk(value, child, keys + (key,)):
                yield item
    elif isinstance(node, list):
        for i, value in enumerate(node):
            child = '%s[%d]' % (path, i)
            yield child, keys + (i,), value
            for item in _walk(value, child, keys + (i,)):
                yield item


NODES = list(_walk(ROBOT, '', ()))
NUMBER_LEAVES = [(p, k) for p, k, v in NODES if isinstance(v, (int, float))]
DICT_KEYS = [(p, k) for p, k, _ in NODES if not isinstance(k[-1], int)]
KEYS_BY_PATH = dict((p, k) for p, k, _ in NODES)


_set = with_value


def _delete(config, keys):
    out = copy.deepcopy(config)
    node = out
    for key in keys[:-1]:
        node = node[key]
    del node[keys[-1]]
    return out


def _error(config, source='robot.yaml'):
    with pytest.raises(rc.RobotConfigError) as info:
        rc.validate(config, source)
    text = str(info.value)
    assert '\n' not in text
    assert text == '%s: %s: %s' % (source, info.value.field, info.value.problem)
    return info.value


# --- examples --------------------------------------------------------------------------------
def test_committed_robot_yaml_is_valid():
    assert rc.problems(ROBOT) == []
    assert rc.load(ROBOT_YAML) == ROBOT


def test_nan_boom_speed_names_file_and_field():
    bad = _set(ROBOT, ('motion', 'speed', 'boom'), float('nan'))
    assert str(_error(bad, '/x/robot.yaml')) == \
        '/x/robot.yaml: motion.speed.boom: NaN is not finite'


def test_nan_spelled_as_text_is_not_a_number():
    # plain `nan` in YAML is a string, and float('nan') of it would be NaN in every reader
    err = _error(_set(ROBOT, ('robot', 'joint_limits', 'lift', 'max'), 'nan'))
    assert err.field == 'robot.joint_limits.lift.max' and 'not a number' in err.problem


def test_absurdly_large_numbers_are_refused():
    # finite, but the readers' arithmetic (forearm + tool, counts) would overflow to infinity
    err = _error(_set(ROBOT, ('robot', 'link_lengths', 'tool'), 1.7e308))
    assert err.field == 'robot.link_lengths.tool' and 'out of range' in err.problem
    assert _error(_set(ROBOT, ('axes',), 10 ** 400)).field == 'axes'


def test_booleans_and_wrong_shapes_are_refused():
    assert _error(_set(ROBOT, ('robot', 'arm_clearance'), True)).field == 'robot.arm_clearance'
    assert _error(_set(ROBOT, ('robot', 'hand_camera', 'xyz'), [0.1, 0.2])).field == \
        'robot.hand_camera.xyz'
    assert _error(_set(ROBOT, ('robot', 'track', 'axis'), [0, 0, 0])).field == 'robot.track.axis'
    assert _error(_set(ROBOT, ('robot', 'joint_limits'), [1, 2])).field == 'robot.joint_limits'
    assert _error([ROBOT]).field == '(document)'


def test_axes_must_be_known_and_unique():
    assert _error(_set(ROBOT, ('axes',), ROBOT['axes'] + ['cart'])).field == 'axes[8]'
    assert _error(_set(ROBOT, ('axes',), ['cart', 'elbow'])).field == 'axes[1]'
    assert _error(_set(ROBOT, ('axes',), [])).field == 'axes'
    assert _error(_set(ROBOT, ('axes',), [['cart']])).field == 'axes[0]'


def test_load_reports_unreadable_and_unparsable_files(tmp_path):
    missing = str(tmp_path / 'none.yaml')
    with pytest.raises(rc.RobotConfigError) as info:
        rc.load(missing)
    assert info.value.field == '(file)' and str(info.value).startswith(missing + ': ')
    broken = tmp_path / 'broken.yaml'
    broken.write_text('robot: [1, 2\n  motion: {\n')
    with pytest.raises(rc.RobotConfigError) as info:
        rc.load(str(broken))
    assert info.value.field == '(file)' and '\n' not in str(info.value)


def test_load_or_exit_logs_one_fatal_line_and_exits_non_zero(tmp_path):
    bad = tmp_path / 'robot.yaml'
    bad.write_text(yaml.safe_dump(_set(ROBOT, ('robot', 'joint_limits', 'boom', 'max'),
                                       float('nan'))))
    lines = []
    with pytest.raises(SystemExit) as info:
        rc.load_or_exit(str(bad), lines.append)
    assert info.value.code == 1
    assert lines == ['%s: robot.joint_limits.boom.max: NaN is not finite' % bad]
    good = []
    assert rc.load_or_exit(ROBOT_YAML, good.append) == ROBOT and good == []


def test_readers_in_this_package_refuse_a_bad_file():
    bad = _set(ROBOT, ('robot', 'link_lengths', 'boom'), float('nan'))
    with pytest.raises(rc.RobotConfigError):
        build_urdf(bad)


# --- properties ------------------------------------------------------------------------------
@PROPERTY
@given(st.sampled_from(NUMBER_LEAVES), st.sampled_from(NON_FINITE))
def test_any_non_finite_number_is_refused_naming_its_field(leaf, value):
    path, keys = leaf
    err = _error(_set(ROBOT, keys, value))
    assert err.field == path
    assert err.problem.endswith('is not finite')


@PROPERTY
@given(st.sampled_from(NUMBER_LEAVES),
       st.one_of(st.text(max_size=5), st.none(), st.booleans(), st.just([1.0]),
                 st.just({'a': 1.0})))
def test_any_number_replaced_by_a_non_number_is_refused_naming_its_field(leaf, value):
    path, keys = leaf
    err = _error(_set(ROBOT, keys, value))
    assert err.field == path


@PROPERTY
@given(st.sampled_from([d for d in DICT_KEYS if d[0] not in OPTIONAL]))
def test_any_required_field_removed_is_reported_missing(entry):
    path, keys = entry
    err = _error(_delete(ROBOT, keys))
    assert (err.field, err.problem) == (path, 'missing')


@PROPERTY
@given(st.sampled_from(LIMIT_PAIRS),
       st.floats(-5e5, 5e5, allow_nan=False), st.floats(0.0, 5e5, allow_nan=False))
def test_limits_must_be_ordered(pair, lo, width):
    keys = KEYS_BY_PATH[pair]
    config = _set(_set(ROBOT, keys + ('min',), lo), keys + ('max',), lo + width)
    if lo < lo + width:
        assert rc.problems(config) == []
    else:
        assert _error(config).field == pair
    flipped = _set(_set(ROBOT, keys + ('min',), lo + width), keys + ('max',), lo)
    assert _error(flipped).field == pair


@PROPERTY
@given(st.floats(-1.0, 1.0, allow_nan=False), st.floats(-1.0, 1.0, allow_nan=False))
def test_the_suction_sleeve_fruit_radii_must_be_ordered_and_positive(lo, hi):
    keys = KEYS_BY_PATH['robot.arms.right.fruit_radius']
    config = _set(_set(ROBOT, keys + ('min',), lo), keys + ('max',), hi)
    if 0.0 < lo < hi:
        assert rc.problems(config) == []
    else:
        assert _error(config).field.startswith('robot.arms.right.fruit_radius')


@PROPERTY
@given(st.sampled_from(POSITIVE), st.floats(-1e6, 1e6, allow_nan=False))
def test_speeds_accelerations_and_lengths_must_be_positive(path, value):
    config = _set(ROBOT, KEYS_BY_PATH[path], value)
    if value > 0.0:
        assert rc.problems(config) == []
    else:
        err = _error(config)
        assert err.field == path and err.problem.startswith('must be > 0')


_JUNK = st.recursive(
    st.one_of(st.none(), st.booleans(), st.floats(), st.integers(), st.text(max_size=4)),
    lambda children: st.one_of(st.lists(children, max_size=4),
                               st.dictionaries(st.sampled_from(['robot', 'motion', 'axes', 'min',
                                                                'max', 'speed', 'track']),
                                               children, max_size=4)),
    max_leaves=20)


@PROPERTY
@given(_JUNK)
def test_arbitrary_documents_are_refused_cleanly_never_crash(document):
    try:
        rc.validate(document)
    except rc.RobotConfigError as exc:
        assert '\n' not in str(exc)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(NUMBER_LEAVES),
                          st.floats(allow_nan=True, allow_infinity=True)), min_size=1,
                max_size=4))
def test_whatever_is_accepted_gives_the_readers_finite_numbers(changes):
    config = ROBOT
    for (_, keys), value in changes:
        config = _set(config, keys, value)
    if rc.problems(config):
        return
    urdf = build_urdf(config).lower()
    assert 'nan' not in urdf and 'inf' not in urdf
    arm = ArmGeometry.from_robot_yaml(config)
    assert all(math.isfinite(v) for p in arm.polyline(0.1, 0.2, 0.3) for v in p)
    limits = manual_ops.limits_from_robot_yaml(config)
    assert all(math.isfinite(a) and math.isfinite(b) and a < b for a, b in limits.values())
