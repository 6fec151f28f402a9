"""The dashboard's pure logic (no ROS master, no Qt): SMACH model and layout, userdata decoding,
executive modes, mission statistics, console filters, diagnostics tree, node health, image
conversion, jog goals and the arm drawing of mission_markers."""
import base64
import math
import os
import pickle
import sys
import tempfile

import numpy as np
import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(PKG, 'src'))
sys.path.insert(0, os.path.join(PKG, '..', 'motion_pkg', 'src'))

from visualization_pkg.arm_geometry import ArmGeometry  # noqa: E402
from visualization_pkg.dashboard import (diagnostics_tree as dt, executive_state as es, image_convert,  # noqa: E402
                                         log_buffer, manual_ops, mission_stats, node_health, smach_model,
                                         userdata)

ROBOT_YAML = os.path.join(PKG, 'config', 'robot.yaml')


# --- SMACH model and layout ------------------------------------------------------------------------
def executive_like_model():
    """A small tree shaped like control_pkg's: ROOT(RUN(MISSION, ESTOP_MONITOR), DO_STOP)."""
    m = smach_model.SmachModel()
    m.update_structure('/SM_ROOT', ['RUN', 'DO_STOP'], ['estop', 'done', 'resume'], ['RUN', 'RUN', 'DO_STOP'],
                       ['DO_STOP', 'succeeded', 'RUN'], ['succeeded', 'aborted'])
    m.update_structure('/SM_ROOT/RUN', ['MISSION', 'ESTOP_MONITOR'], ['succeeded', 'estop'],
                       ['MISSION', 'ESTOP_MONITOR'], ['done', 'estop'], ['done', 'estop'])
    m.update_structure('/SM_ROOT/RUN/MISSION', ['DO_START', 'NEXT_TARGET', 'PICK', 'DO_ERROR'],
                       ['succeeded', 'target', 'done', 'picked', 'aborted', 'aborted'],
                       ['DO_START', 'NEXT_TARGET', 'NEXT_TARGET', 'PICK', 'PICK', 'DO_ERROR'],
                       ['NEXT_TARGET', 'PICK', 'succeeded', 'NEXT_TARGET', 'DO_ERROR', 'aborted'],
                       ['succeeded', 'aborted', 'preempted'])
    m.update_status('/SM_ROOT', ['RUN'], ['RUN'], '')
    m.update_status('/SM_ROOT/RUN', [], ['MISSION', 'ESTOP_MONITOR'], '')
    m.update_status('/SM_ROOT/RUN/MISSION', ['DO_START'], ['PICK'], '')
    return m


def test_active_paths_follow_active_parents_only():
    m = executive_like_model()
    assert m.active_leaves() == ['/SM_ROOT/RUN/ESTOP_MONITOR', '/SM_ROOT/RUN/MISSION/PICK']
    assert '/SM_ROOT/RUN' in m.active_paths()
    # emergency stop: the root moves to DO_STOP; the stale MISSION status no longer counts
    assert m.update_status('/SM_ROOT', ['RUN'], ['DO_STOP'], '')
    assert m.active_leaves() == ['/SM_ROOT/DO_STOP']
    assert not m.update_status('/SM_ROOT', ['RUN'], ['DO_STOP'], 'x')     # same states: no change
    m.update_status('/SM_ROOT', ['RUN'], ['None'], '')
    assert m.active_paths() == set()


def test_follow_root_and_owner():
    m = executive_like_model()
    assert m.deepest_active_container() == '/SM_ROOT/RUN/MISSION'
    assert m.follow_root(1) == '/SM_ROOT/RUN/MISSION'
    assert m.follow_root(2) == '/SM_ROOT/RUN'
    assert m.follow_root(9) == '/SM_ROOT'
    assert m.owner_of('/SM_ROOT/RUN/MISSION/PICK') == '/SM_ROOT/RUN/MISSION'
    assert m.owner_of('/SM_ROOT/RUN') == '/SM_ROOT/RUN'
    assert m.roots() == ['/SM_ROOT']


def test_layered_order_finds_back_edges():
    children = ['A', 'B', 'C', 'D']
    edges = [('x', 'A', 'B'), ('y', 'B', 'C'), ('z', 'C', 'B'), ('w', 'C', 'D'), ('v', 'A', 'D')]
    layer, back = smach_model.layered_order(children, edges, ['A'])
    assert layer == {'A': 0, 'B': 1, 'C': 2, 'D': 3}
    assert back == {('C', 'B')}


def _measure(text):
    return 7.0 * len(text), 12.0


def _overlap(a, b):
    return a.x < b.x + b.w and b.x < a.x + a.w and a.y < b.y + b.h and b.y < a.y + a.h


def test_layout_boxes_nest_and_do_not_overlap():
    m = executive_like_model()
    block = smach_model.layout(m, '/SM_ROOT', 3, _measure)
    nodes = list(block.walk())
    keys = set(n.key for n in nodes)
    assert '/SM_ROOT/RUN/MISSION/PICK' in keys
    assert smach_model.outcome_key('/SM_ROOT', 'aborted') in keys
    for b in [block] + [n.block for n in nodes if n.block is not None]:
        for i, a in enumerate(b.nodes):
            for c in b.nodes[i + 1:]:
                assert not _overlap(a, c), (a.key, c.key)
    for n in nodes:
        if n.block is not None:
            for child in n.block.nodes:
                assert n.x <= child.x and child.x + child.w <= n.x + n.w + 1e-6
                assert n.y <= child.y and child.y + child.h <= n.y + n.h + 1e-6
    for a, b, _label, _back in block.all_edges():
        assert a in keys and b in keys
    mission = [n for n in nodes if n.key.startswith('/SM_ROOT/RUN/MISSION/')]
    rows = dict((n.label, n.layer) for n in mission if n.kind != 'outcome')
    assert rows['DO_START'] < rows['NEXT_TARGET'] < rows['PICK'] < rows['DO_ERROR']
    outcome_rows = set(n.layer for n in nodes if n.kind == 'outcome' and n.key.startswith('/SM_ROOT/RUN/MISSION/:'))
    assert outcome_rows == {max(rows.values()) + 1}
    # depth 1: containers drawn collapsed
    flat = smach_model.layout(m, '/SM_ROOT', 1, _measure)
    assert [n.kind for n in flat.nodes if n.label == 'RUN'] == ['collapsed']
    assert smach_model.layout(m, '/nope', 2, _measure) is None


# --- userdata ----------------------------------------------------------------------------------------
def _encode(data):
    return base64.b64encode(pickle.dumps(data, 2)).decode('ascii')


def test_userdata_round_trip_and_messages():
    geometry_msgs = pytest.importorskip('geometry_msgs.msg')
    p = geometry_msgs.PointStamped()
    p.header.frame_id = 'base_link'
    p.point.x = 0.5
    data, error = userdata.decode(_encode({'picking_point': 2, 'targets': [p], 'joint_goal': [0.1, 0.2, 0.3]}))
    assert error == ''
    assert data['picking_point'] == 2
    assert data['targets'][0].point.x == 0.5
    summary, kids = userdata.describe(data)
    assert summary == 'dict (3)'
    described = dict(kids)
    assert described['joint_goal'][0] == '[0.1, 0.2, 0.3]'
    target = dict(described['targets'][1])['[0]']
    assert target[0] == 'geometry_msgs/PointStamped'
    assert userdata.decode('') == ({}, '')
    assert userdata.decode('%%%')[1]
    assert 'unpickle' in userdata.decode(base64.b64encode(b'not a pickle').decode())[1]


class _Evil(object):
    def __reduce__(self):
        return (os.system, ('touch %s' % _Evil.target,))


def test_userdata_never_runs_code_from_the_network():
    target = os.path.join(tempfile.mkdtemp(), 'pwned')
    _Evil.target = target
    data, error = userdata.decode(_encode({'x': _Evil()}))
    assert not os.path.exists(target)
    assert isinstance(data['x'], userdata.Opaque)
    assert 'system' in repr(data['x'])


# --- executive state -------------------------------------------------------------------------------
def test_executive_modes_and_manual_gate():
    s = es.ExecutiveState(now=100.0)
    assert s.mode(101.0) == es.UNKNOWN
    assert not s.manual_allowed(101.0)[0]
    assert s.mode(104.0) == es.OFFLINE
    assert s.manual_allowed(104.0)[0]
    s.update_root(['None'], 105.0)
    assert s.mode(105.0) == es.IDLE
    s.update_root(['RUN'], 106.0)
    allowed, reason = s.manual_allowed(106.0)
    assert not allowed and 'mission is running' in reason
    s.update_text('DO_STOP: axes halted: halted', 106.5)     # text newer than the status
    assert s.mode(106.5) == es.PAUSED
    s.update_root(['DO_STOP'], 107.0)
    assert s.stop_confirmed(107.0) and s.manual_allowed(107.0)[0]
    s.update_text('DO_STOP: mission resumed', 108.0)
    assert s.mode(108.0) == es.RUNNING
    s.update_root(['RUN'], 108.1)
    assert s.mode(108.1 + 8.0) == es.OFFLINE                  # heartbeats stopped: executive gone


# --- mission statistics ------------------------------------------------------------------------------
def test_mission_stats():
    st = mission_stats.MissionStats()
    st.add_event('m1', 'state', 'NEXT_POINT', 'picking point 0', 1.0)
    f = st.add_record('m1', 0, 4, 0, '', ['DO_KINEMATICS', 'DO_MOVE_ROBOT', 'DO_MOVE_ROBOT'], [0.5, 2.0, 1.5], 4.5)
    assert f.stage_totals() == [('DO_KINEMATICS', 0.5), ('DO_MOVE_ROBOT', 3.5)]
    st.add_record('m1', 0, 5, 1, 'beyond reach', ['DO_KINEMATICS'], [0.2], 0.3)
    assert st.counts() == {'picked': 1, 'unreachable': 1, 'lost': 0, 'failed': 0}
    assert st.mean_cycle() == 4.5
    assert st.points == [0]
    assert 'mean pick cycle 4.5 s' in st.progress_text()
    st.add_event('m1', 'summary', '', '{"picked": 1}', 2.0)
    assert st.summary == {'picked': 1}
    st.add_record('m2', 1, 1, 0, '', [], [], 1.0)            # a new mission starts afresh
    assert st.mission_id == 'm2' and len(st.fruits) == 1 and st.summary is None


# --- console, diagnostics, nodes --------------------------------------------------------------------
def test_log_filter():
    buf = log_buffer.LogBuffer(size=3)
    for i, (level, node) in enumerate([(2, '/a'), (4, '/b'), (8, '/a'), (2, '/b')]):
        buf.add(log_buffer.Entry(i, level, node, 'message %d' % i))
    assert len(buf.entries) == 3                              # the oldest dropped
    assert [e.msg for e in buf.filtered(log_buffer.LogFilter(min_level=4))] == ['message 1', 'message 2']
    assert [e.msg for e in buf.filtered(log_buffer.LogFilter(nodes=['/b']))] == ['message 1', 'message 3']
    assert [e.msg for e in buf.filtered(log_buffer.LogFilter(text='MESSAGE 2'))] == ['message 2']
    assert log_buffer.level_name(8) == 'ERROR'


def test_diagnostics_tree_levels():
    root = dt.build_tree([('/Sense/Motion/Modbus', dt.ERROR, 'refused', 'hw', [('k', 'v')]),
                          ('/Sense/Motion/Axis cart', dt.OK, 'ok', '', []),
                          ('/Sense/Vision/stereo', dt.STALE, '', '', []),
                          ('/Data', dt.OK, 'all ok', '', [])])
    sense = root.children['Sense']
    assert sense.effective_level() == dt.ERROR
    assert sense.children['Vision'].effective_level() == dt.STALE
    assert [n.path for n in dt.flatten(root)][:2] == ['/Data', '/Sense']
    assert dt.worse(dt.WARN, dt.STALE) == dt.STALE and dt.worse(dt.STALE, dt.ERROR) == dt.ERROR


def test_node_health():
    h = node_health.NodeHealth(expected=['task_planner', '/motion_server'])
    rows = h.update({'/task_planner', '/other'}, {'/task_planner': (True, 'pid 1'), '/other': (True, 'pid 2')})
    states = dict((r.name, r.state) for r in rows)
    assert states == {'/task_planner': 'alive', '/other': 'alive', '/motion_server': 'missing'}
    h.update({'/task_planner', '/other'}, {'/task_planner': (False, 'refused'), '/other': (True, '')})
    assert h.state('task_planner') == 'dead'                  # registered but not answering
    h.update({'/task_planner'}, {'/task_planner': (True, '')})
    assert h.state('/other') == 'dead'                        # seen before, now gone
    h.forget('/other')
    h.update({'/task_planner'}, {'/task_planner': (True, '')})
    assert h.state('/other') is None


# --- images ------------------------------------------------------------------------------------------
def test_image_conversion():
    h, w = 4, 6
    bgr = np.zeros((h, w, 3), np.uint8)
    bgr[..., 0] = 255                                         # blue
    padded = np.zeros((h, w * 3 + 2), np.uint8)               # row padding (step > width * 3)
    padded[:, :w * 3] = bgr.reshape(h, -1)
    out = image_convert.to_rgb('bgr8', h, w, w * 3 + 2, padded.tobytes())
    assert out.shape == (h, w, 3) and tuple(out[0, 0]) == (0, 0, 255)
    rgba = np.full((h, w, 4), (10, 20, 30, 40), np.uint8)
    assert tuple(image_convert.to_rgb('rgba8', h, w, w * 4, rgba.tobytes())[1, 1]) == (10, 20, 30)
    depth = np.array([[0.5, 1.5], [np.nan, 2.5]], '<f4')
    d = image_convert.to_rgb('32FC1', 2, 2, 8, depth.tobytes())
    assert d[0, 0, 0] == 0 and d[1, 1, 0] == 255 and d[1, 0, 0] == 0
    mono16 = np.array([[0, 1000]], '>u2')
    assert image_convert.to_rgb('mono16', 1, 2, 4, mono16.tobytes())[0, 1, 0] == 255
    big = image_convert.to_rgb('mono8', 10, 100, 100, bytes(1000), max_width=30)
    assert big.shape[1] <= 30
    with pytest.raises(image_convert.UnsupportedEncoding):
        image_convert.to_rgb('yuv422', 2, 2, 4, bytes(8))
    with pytest.raises(ValueError):
        image_convert.to_rgb('rgb8', 4, 4, 12, bytes(10))


# --- manual operation ------------------------------------------------------------------------------
def test_jog_goal():
    with open(ROBOT_YAML) as f:
        limits = manual_ops.limits_from_robot_yaml(yaml.safe_load(f))
    assert limits['left_lift_joint'] == (0.0, 0.30)
    pos = {'left_lift_joint': 0.1, 'left_boom_joint': 0.5, 'left_forearm_joint': -0.2}
    left, goal, note = manual_ops.jog_goal('left_boom_joint', 0.1, pos, limits)
    assert left is True and goal == pytest.approx([0.1, 0.6, -0.2]) and note == ''
    left, goal, note = manual_ops.jog_goal('left_lift_joint', 0.5, pos, limits)
    assert goal[0] == 0.30 and 'clamped' in note
    with pytest.raises(ValueError, match='no joint_states'):
        manual_ops.jog_goal('right_lift_joint', 0.01, pos, limits)
    with pytest.raises(ValueError):
        manual_ops.jog_goal('left_boom_joint', float('nan'), pos, limits)
    with pytest.raises(ValueError):
        manual_ops.jog_goal('cart_joint', 0.1, pos, limits)
    assert len(manual_ops.jog_joint_names()) == 6


# --- the arm drawn by mission_markers agrees with the kinematics -----------------------------------
def test_arm_polyline_matches_kinematics():
    kin = pytest.importorskip('motion_pkg.kinematics')
    geom = kin.RobotGeometry.from_yaml(ROBOT_YAML)
    with open(ROBOT_YAML) as f:
        arm = ArmGeometry.from_robot_yaml(yaml.safe_load(f))
    rng = np.random.RandomState(3)
    tcp_frame = {'left': 'left_shear_tcp', 'right': 'right_suction_tcp'}
    for _ in range(20):
        side = ['left', 'right'][rng.randint(2)]
        q = (rng.uniform(0, 0.3), rng.uniform(-2.6, 2.6), rng.uniform(-2.6, 2.6))
        joints = {'%s_lift_joint' % side: q[0], '%s_boom_joint' % side: q[1], '%s_forearm_joint' % side: q[2],
                  'waist_joint': rng.uniform(-1, 1), 'cart_joint': rng.uniform(0, 3)}
        poses = geom.frame_transforms(joints)
        base = poses['%s_arm_base' % side]
        tcp_in_base = np.linalg.inv(base).dot(poses[tcp_frame[side]])[:3, 3]
        assert np.allclose(arm.tool_centre(*q), tcp_in_base, atol=1e-9)
        assert math.hypot(*arm.polyline(*q)[2][:2]) == pytest.approx(arm.boom)
