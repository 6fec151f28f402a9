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

from visualization_pkg.arm_geometry import ArmGeometry  # noqa: E402
from visualization_pkg.dashboard import (diagnostics_tree as dt, executive_state as es, image_convert,  # noqa: E402
                                         log_buffer, manual_ops, mission_stats, node_health, smach_model,
                                         userdata)

DESCRIPTION = os.path.join(os.path.dirname(PKG), 'harvest_description')
ROBOT_YAML = os.path.join(DESCRIPTION, 'config', 'robot.yaml')


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
    assert st.counts() == {'picked': 1, 'unreachable': 1, 'lost': 0, 'failed': 0, 'dropped': 0}
    st.add_record('m1', 0, 6, 4, 'dropped on the way to the box', [], [], 9.0)   # OUTCOME_DROPPED
    assert st.counts()['dropped'] == 1 and st.fruits[-1].outcome == 'dropped'
    assert '1 dropped' in st.progress_text()
    assert st.mean_cycle() == 4.5
    assert st.points == [0]
    assert 'mean pick cycle 4.5 s' in st.progress_text()
    st.add_event('m1', 'summary', '', '{"picked": 1}', 2.0)
    assert st.summary == {'picked': 1}
    st.add_record('m2', 1, 1, 0, '', [], [], 1.0)            # a new mission starts afresh
    assert st.mission_id == 'm2' and len(st.fruits) == 1 and st.summary is None


def test_mission_stats_names_the_pick_records_outcomes():
    from harvest_msgs.msg import PickRecord
    constants = [n for n in dir(PickRecord) if n.startswith('OUTCOME_')]
    assert len(mission_stats.OUTCOMES) == len(constants)
    for name in constants:
        assert mission_stats.outcome_name(getattr(PickRecord, name)) == name[len('OUTCOME_'):].lower()
    assert mission_stats.outcome_name(len(constants)) == 'outcome %d' % len(constants)


def test_mission_markers_colour_every_outcome():
    from harvest_msgs.msg import PickRecord
    from visualization_pkg import mission_markers
    codes = set(getattr(PickRecord, n) for n in dir(PickRecord) if n.startswith('OUTCOME_'))
    assert set(mission_markers.OUTCOME_RGBA) == codes


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


# --- node module: start / stop / restart (fake rosnode / roslaunch layer) ---------------------------
from visualization_pkg.dashboard import node_control as nc  # noqa: E402
from visualization_pkg.dashboard import operator_events, shell_session  # noqa: E402


class FakeLayer(object):
    """rosnode/roslaunch stand-in: a dict of running nodes {name: pid}; respawning nodes come back."""

    def __init__(self, running, specs, respawns=()):
        self.running = dict(running)
        self.specs = specs
        self.respawns = set(respawns)
        self.calls = []
        self.next_pid = 1000

    def pid(self, name):
        return self.running.get(name)

    def kill(self, name):
        self.calls.append(('kill', name))
        if name not in self.running:
            return False, 'unknown node'
        del self.running[name]
        if name in self.respawns:
            self.next_pid += 1
            self.running[name] = self.next_pid
        return True, 'killed'

    def spec(self, name):
        spec = self.specs.get(name)
        return (spec, '') if spec else (None, '%s runs on another machine' % name)

    def launch(self, spec):
        self.calls.append(('launch', spec.name))
        self.next_pid += 1
        self.running[spec.name] = self.next_pid
        return ('handle', spec.name)

    def stop_process(self, handle):
        self.calls.append(('stop_process', handle[1]))
        self.running.pop(handle[1], None)


def test_node_restart_relaunches_with_the_spec_of_its_registration():
    spec = nc.NodeSpec('/motion_server', 'motion_pkg', 'motion_server', '/', '', [('joint_states', 'js')])
    layer = FakeLayer({'/motion_server': 11}, {'/motion_server': spec})
    ctl = nc.NodeController(layer)
    status, text, to_launch = ctl.restart('motion_server', wait_back=lambda n, p: pytest.fail('not respawned'))
    assert status == nc.OK and to_launch is spec and layer.calls == [('kill', '/motion_server')]
    assert ctl.launch(to_launch)[0] == nc.OK
    assert layer.calls[-1] == ('launch', '/motion_server') and '/motion_server' in ctl.launched
    # a node this dashboard launched: restart stops its process and launches it again
    status, _text, to_launch = ctl.restart('/motion_server', wait_back=lambda n, p: pytest.fail('own node'))
    assert status == nc.OK and ('stop_process', '/motion_server') in layer.calls and to_launch is spec
    ctl.shutdown()
    assert layer.calls[-1] == ('stop_process', '/motion_server') and not ctl.launched


def test_node_restart_of_a_respawned_node_waits_and_launches_nothing():
    spec = nc.NodeSpec('/image_processing', 'vision_pkg', 'image_processing', respawn=True)
    layer = FakeLayer({'/image_processing': 20}, {'/image_processing': spec}, respawns=['/image_processing'])
    waited = []
    ctl = nc.NodeController(layer)
    status, text, to_launch = ctl.restart('/image_processing',
                                          lambda n, old: waited.append(old) or layer.pid(n) not in (None, old))
    assert (status, to_launch, waited) == (nc.OK, None, [20]) and 'respawned' in text
    assert not [c for c in layer.calls if c[0] == 'launch']
    status, text, _ = ctl.restart('/image_processing', lambda n, old: False)
    assert status == nc.FAILED and 'did not respawn' in text


def test_node_restart_without_package_is_refused_before_any_kill():
    layer = FakeLayer({'/remote_node': 5}, {})
    ctl = nc.NodeController(layer)
    status, text, to_launch = ctl.restart('/remote_node', lambda n, p: True)
    assert status == nc.REFUSED and to_launch is None and 'another machine' in text and 'refused' in text
    assert layer.calls == [] and layer.pid('/remote_node') == 5
    assert ctl.start('/remote_node')[0] == nc.REFUSED           # running already


def test_node_stop_then_start_uses_the_spec_seen_at_the_stop():
    spec = nc.NodeSpec('/robot/dummy', 'visualization_pkg', 'dummy_node', '/robot/')
    layer = FakeLayer({'/robot/dummy': 3}, {'/robot/dummy': spec})
    ctl = nc.NodeController(layer)
    assert ctl.stop('/robot/dummy')[0] == nc.OK and layer.pid('/robot/dummy') is None
    layer.specs = {}                                            # gone from the graph: no spec any more
    status, text = ctl.start('/robot/dummy')
    assert status == nc.OK and layer.calls[-1] == ('launch', '/robot/dummy')
    assert ctl.stop('/never_ran')[0] == nc.REFUSED


def test_node_spec_from_a_command_line():
    pkgs = {'/ws/src/motion_pkg/scripts/motion_server': 'motion_pkg', '/opt/ros/lib/rosout/rosout': 'rosout'}
    spec, why = nc.spec_from_cmdline('/robot/motion_server',
                                     ['/ws/.venv/bin/python', '/ws/src/motion_pkg/scripts/motion_server',
                                      '--fast', 'joint_states:=js', '__name:=motion_server', '__log:=/x.log'],
                                     pkgs.get)
    assert (spec.package, spec.node_type, spec.namespace, spec.args, spec.remaps) == (
        'motion_pkg', 'motion_server', '/robot/', '--fast', [('joint_states', 'js')]) and not why
    assert spec.base_name == 'motion_server'
    spec, _ = nc.spec_from_cmdline('/rosout', ['/opt/ros/lib/rosout/rosout', '__name:=rosout'], pkgs.get)
    assert (spec.package, spec.node_type, spec.namespace) == ('rosout', 'rosout', '/')
    spec, why = nc.spec_from_cmdline('/x', ['/usr/bin/python3', '/tmp/x.py'], pkgs.get)
    assert spec is None and 'not inside a ROS package' in why
    assert nc.spec_from_cmdline('/x', [], pkgs.get)[0] is None


def test_node_layer_finds_the_package_of_a_script():
    from visualization_pkg.dashboard.node_layer import package_of
    assert package_of(os.path.join(PKG, 'scripts', 'harvest_dashboard')) == 'visualization_pkg'
    assert package_of('/opt/ros/noetic/lib/rosout/rosout') == 'rosout'


# --- operator events, shell logic, waist jog, rviz fallback -----------------------------------------
def test_operator_events_follow_the_mission_id():
    tracker = operator_events.MissionIdTracker(operator_events.fallback_mission_id(0))
    assert tracker.mission_id() == 'operator-19700101'
    tracker.seen('operator-19700101')                            # our own echo does not count
    tracker.seen('m-42')
    assert operator_events.event_fields(tracker, 'node_stop', 'ok', '/a stopped') == (
        'm-42', 'operator', 'node_stop', 'ok: /a stopped')


def test_shell_history_and_interrupt_targets():
    h = shell_session.CommandHistory()
    for line in ('ls', 'ls', '', 'echo hi'):
        h.add(line)
    assert h.items == ['ls', 'echo hi']
    assert h.up('draft') == 'echo hi' and h.up('echo hi') == 'ls' and h.up('ls') == 'ls'
    assert h.down('ls') == 'echo hi' and h.down('echo hi') == 'draft'
    parents = {10: 1, 11: 10, 12: 11, 13: 10, 20: 1}
    assert shell_session.descendants(10, parents) == [11, 13, 12]
    sent = []
    assert shell_session.interrupt(10, parents, kill=lambda pid, sig: sent.append((pid, sig))) == [11, 13, 12]
    assert all(sig == shell_session.signal.SIGINT for _pid, sig in sent) and 10 not in [p for p, _ in sent]
    assert shell_session.interrupt(20, parents, kill=lambda pid, sig: pytest.fail('idle')) == []
    rc = shell_session.rc_text(["/w/it's/devel/setup.bash"])
    assert ". '/w/it'\\''s/devel/setup.bash'" in rc


def test_waist_jog_target_and_limits():
    with open(ROBOT_YAML) as f:
        robot = yaml.safe_load(f)
    limits = manual_ops.limits_from_robot_yaml(robot)
    assert limits[manual_ops.WAIST_JOINT] == (robot['robot']['waist']['min'], robot['robot']['waist']['max'])
    assert manual_ops.waist_jog_target(0.1, {'waist_joint': 0.2}, limits) == (pytest.approx(0.3), '')
    target, note = manual_ops.waist_jog_target(1.0, {'waist_joint': 3.0}, limits)
    assert target == limits['waist_joint'][1] and 'clamped' in note
    with pytest.raises(ValueError):
        manual_ops.waist_jog_target(0.1, {}, limits)


def test_rviz_embedding_blockers():
    pytest.importorskip('python_qt_binding.QtWidgets')
    from visualization_pkg.dashboard import rviz_panel as rp
    assert 'offscreen' in rp.embed_blocker('offscreen', {'DISPLAY': ':0'})
    assert rp.embed_blocker('xcb', {}) == 'no DISPLAY' and rp.embed_blocker('xcb', {'DISPLAY': ':1'}) == ''
    assert rp.window_blocker({}) == 'no display'
    assert rp.window_blocker({'DISPLAY': ':1'}, which=lambda n: None) == 'rosrun not found'
    assert 'own window' in rp.fallback_line('x', '') and 'cannot run here' in rp.fallback_line('x', 'no display')
    panel, reason = rp.make_rviz('', 'xcb', {'DISPLAY': ':1'}, probe_fn=lambda: 'rviz cannot initialise here (y)')
    assert panel is None and ('cannot initialise' in reason or 'bindings' in reason)


def test_launch_arguments_of_roslaunch_and_of_catkins_rostest():
    # catkin's run_tests runs rostest with options whose values are separate words; taken for
    # launch files they hid the node's declaration (respawn) from the node module
    from visualization_pkg.dashboard import node_control as nc
    argv = ['/ws/.venv/bin/python', '/usr/bin/rostest', '--pkgdir=/ws/src/visualization_pkg',
            '--package=visualization_pkg', '--results-filename', 'test_node_control.xml',
            '--results-base-dir', '/ws/build/test_results', '/ws/src/x/test/node_control.test']
    assert nc.launch_arguments(argv) == (['/ws/src/x/test/node_control.test'], [])
    argv = ['/usr/bin/python3', '/usr/bin/roslaunch', '-p', '11412', 'harvest_bringup',
            'sim.launch', 'scenario:=three_targets', '--wait']
    assert nc.launch_arguments(argv) == (['harvest_bringup', 'sim.launch'],
                                         ['scenario:=three_targets'])
    assert nc.launch_arguments(['/usr/bin/python3', '/opt/x/node.py']) == ([], [])


def test_children_get_the_default_sigint_even_when_the_dashboard_ignores_it():
    # a background job of a non-interactive shell (as under make) starts with SIGINT ignored,
    # and an ignored signal stays ignored across exec: Ctrl-C in the shell panel did nothing
    import signal
    import subprocess
    import sys
    from visualization_pkg.dashboard.shell_session import DefaultSigintForChildren
    probe = [sys.executable, '-c',
             'import signal; print(signal.getsignal(signal.SIGINT) is signal.SIG_IGN)']
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        assert subprocess.check_output(probe).strip() == b'True'       # the trouble itself
        with DefaultSigintForChildren():
            assert subprocess.check_output(probe).strip() == b'False'
            assert signal.getsignal(signal.SIGINT) is not signal.SIG_IGN
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN, 'put back as it was'
    finally:
        signal.signal(signal.SIGINT, old)
