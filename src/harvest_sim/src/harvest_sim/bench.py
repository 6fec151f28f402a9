"""Benchmark of the simulator (scripts/bench_sim): render cost, per-stage costs and the speed the
whole stack reaches.

1. Render cost, in this process: full re-renders of the stereo pair and the hand camera on a
   scenario (the pose changes every frame, so no cache helps), and the cost of a frame of a still
   scene (cached layer, noise, blur).
2. Stage costs (--profile), in this process, on a rendered pair: rospy (de)serialisation of a
   1024x768 bgr8 Image and of stereo_image_proc's 1024x768 XYZRGB PointCloud2, the stereo work
   of stereo_image_proc (rectification remaps, StereoBM with the robot's parameters, point
   cloud), the detector on the right image, the point-cloud decoding and localisation of
   image_processing, a tf2 lookup.
3. Whole-stack runs: for every --scales value a private master (free port) runs
   `harvest_bringup sim.launch` (its own controller port and serial number: harvest_sim.instance) (simulated plant factory + the whole robot stack) on --scenario
   to the end of the mission; prints the speed reached (simulated / wall seconds from the first
   /clock tick to the mission summary), the mission's result from the simulator's ground truth
   and the executive's mean cycle time. With --profile, the run at --profile-scale also prints
   the CPU share of every node and the frames each stage handled (from ROS topic statistics),
   hence CPU ms per frame.
4. --sim-only: the older live run of sim_robot.launch alone (robot still, then moving).
This is a tool, not a node: it waits in wall time (rospy.rostime.wallsleep) and reads /proc.
"""

import argparse
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np
from rospy.rostime import wallsleep  # wall time on purpose: the harness measures sim vs wall time

from harvest_sim import instance

#: rows of the per-node profile: (label, node names, topic whose frames the node handles)
PROFILE_ROWS = (
    ('renderer, stereo pair', ('sim_stereo_camera',), 'stereo'),
    ('renderer, hand camera', ('sim_hand_camera',), 'hand'),
    ('image relays (stereo)', ('dual_eye_image_capture',), 'stereo'),
    ('image relays (hand)', ('single_eye_image_capture',), 'hand'),
    ('stereo_image_proc (rectify, BM, points2)', ('stereo_image_proc',), 'points2'),
    ('image_processing (detection, localisation, subs)', ('image_processing',), 'points2'),
    ('tf: robot_state_publisher', ('robot_state_publisher',), None),
    ('sim_clock', ('sim_clock',), None),
    ('Modbus: motion_server + sim_controller', ('motion_server', 'sim_controller'), None),
    ('sim_world', ('sim_world',), None),
    ('executive, self-test, kinematics, database, servo',
     ('task_planner', 'self_test_server', 'kinematics_server', 'database_node', 'visual_servo'),
     None),
)


def _paths():
    here = os.path.dirname(os.path.abspath(__file__))
    pkg = os.path.normpath(os.path.join(here, '..', '..'))
    try:
        import rospkg
        rp = rospkg.RosPack()
        return rp.get_path('harvest_sim'), os.path.join(rp.get_path('harvest_description'),
                                                        'config', 'robot.yaml')
    except Exception:      # noqa: BLE001 - no ROS environment: source tree
        return pkg, os.path.join(pkg, '..', 'harvest_description', 'config', 'robot.yaml')


def _median_ms(fn, repeat):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t) * 1000.0)
    return float(np.median(times))


def _scene(scenario_name):
    from harvest_sim import render, scenario as scn
    from motion_pkg.kinematics import RobotGeometry
    pkg, robot = _paths()
    geom = RobotGeometry.from_yaml(robot)
    s = scn.load_scenario(scn.resolve_scenario(scenario_name, os.path.join(pkg, 'scenarios')))
    return s, geom, render


def render_cost(scenario_name, frames, save_image=None):
    """Mean / median ms per stereo eye frame and per hand frame (full re-render each time), and
    the median ms of a frame of a still scene (cached layer)."""
    from harvest_sim import camera_model
    s, geom, render = _scene(scenario_name)
    t0 = time.perf_counter()
    r = render.Renderer(s)
    init_ms = (time.perf_counter() - t0) * 1000
    fr = render.fruits_from_scenario(s)
    stereo, hand = camera_model.stereo_camera(), camera_model.hand_camera()
    y0 = s.track.picking_points[0]
    ik = geom.inverse('left', (0.5, 0.0, 1.0))
    res = {'init_ms': init_ms, 'stereo_ms': [], 'hand_ms': []}
    still = geom.frame_transforms({'cart_joint': y0})
    r.render(stereo, still['stereo_left_optical'], fr, ('left', 0))   # warm caches
    for i in range(frames):
        poses = geom.frame_transforms({'cart_joint': y0 + 0.002 * (i + 1),
                                       'left_lift_joint': ik.joints[0] + 0.001 * i,
                                       'left_boom_joint': ik.joints[1],
                                       'left_forearm_joint': ik.joints[2]})
        for eye in ('stereo_left_optical', 'stereo_right_optical'):
            t = time.perf_counter()
            r.render(stereo, poses[eye], fr, (eye, i))
            res['stereo_ms'].append((time.perf_counter() - t) * 1000)
        t = time.perf_counter()
        r.render(hand, poses['hand_camera_optical'], fr, ('hand', i))
        res['hand_ms'].append((time.perf_counter() - t) * 1000)
    counter = [0]

    def cached():
        counter[0] += 1
        r.render(stereo, still['stereo_left_optical'], fr, ('left', counter[0]))
    res['cached_ms'] = _median_ms(cached, max(5, frames))
    if save_image:
        import cv2
        cv2.imwrite(save_image, r.render(stereo, still['stereo_left_optical'], fr, ('left', 0)))
    return res


def stage_costs(scenario_name, repeat=7):
    """Median ms of the per-frame stages of the perception pipeline, in this process."""
    import io
    import cv2
    import rospkg
    import yaml
    from sensor_msgs.msg import Image, PointCloud2, PointField
    from harvest_sim import camera_model
    out = {}
    s, geom, render = _scene(scenario_name)
    r = render.Renderer(s)
    fr = render.fruits_from_scenario(s)
    cam = camera_model.stereo_camera()
    poses = geom.frame_transforms({'cart_joint': s.track.picking_points[0]})
    left = r.render(cam, poses['stereo_left_optical'], fr, ('left', 0))
    right = r.render(cam, poses['stereo_right_optical'], fr, ('right', 0))
    msg = Image(height=cam.height, width=cam.width, encoding='bgr8', step=cam.width * 3,
                data=left.tobytes())
    buf = io.BytesIO()
    msg.serialize(buf)
    data = buf.getvalue()

    def ser():
        b = io.BytesIO()
        msg.serialize(b)
    out['Image 1024x768 bgr8: serialise'] = _median_ms(ser, repeat)
    out['Image 1024x768 bgr8: deserialise'] = _median_ms(lambda: Image().deserialize(data),
                                                         repeat)
    fields = [PointField(name=n, offset=o, datatype=PointField.FLOAT32, count=1)
              for n, o in (('x', 0), ('y', 4), ('z', 8), ('rgb', 16))]
    cloud = PointCloud2(height=cam.height, width=cam.width, fields=fields, point_step=32,
                        row_step=32 * cam.width, is_dense=False,
                        data=bytes(32 * cam.width * cam.height))
    buf = io.BytesIO()
    cloud.serialize(buf)
    cdata = buf.getvalue()
    out['PointCloud2 1024x768 XYZRGB (25 MB): serialise'] = _median_ms(
        lambda: cloud.serialize(io.BytesIO()), repeat)
    out['PointCloud2 1024x768 XYZRGB: deserialise'] = _median_ms(
        lambda: PointCloud2().deserialize(cdata), repeat)
    # stereo_image_proc's work: rectify both eyes (colour + mono), block matching, point cloud
    mapx, mapy = np.meshgrid(np.arange(cam.width, dtype=np.float32),
                             np.arange(cam.height, dtype=np.float32))

    def rectify():
        for img in (left, right):
            cv2.remap(img, mapx, mapy, cv2.INTER_LINEAR)
            cv2.remap(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY), mapx, mapy, cv2.INTER_LINEAR)
    out['stereo: rectify both eyes (colour + mono remaps)'] = _median_ms(rectify, repeat)
    try:
        from vision_pkg import localisation
        vp = rospkg.RosPack().get_path('vision_pkg')
        with open(os.path.join(vp, 'config', 'stereo_image_proc.yaml')) as f:
            params = yaml.safe_load(f)
        bm = localisation.stereo_bm_from_params(params)
        gl, gr = cv2.cvtColor(left, cv2.COLOR_BGR2GRAY), cv2.cvtColor(right, cv2.COLOR_BGR2GRAY)
        out['stereo: StereoBM (robot parameters)'] = _median_ms(lambda: bm.compute(gl, gr),
                                                                 repeat)
        disp = bm.compute(gl, gr).astype(np.float32) / 16.0
        disp[disp < params.get('min_disparity', 0)] = np.nan
        baseline = geom.stereo_baseline
        out['stereo: disparity -> organised cloud'] = _median_ms(
            lambda: localisation.cloud_from_disparity(disp, cam.fx, cam.fy, cam.cx, cam.cy,
                                                      baseline), repeat)
        from vision_pkg.detection import TomatoDetector
        vcfg = os.path.join(vp, 'config', 'image_processing.yaml')
        with open(vcfg) as f:
            det_params = yaml.safe_load(f).get('stereo_detection', {})
        det = TomatoDetector(**det_params)
        out['detection: stereo right image (1024x768)'] = _median_ms(lambda: det.detect(right),
                                                                     repeat)
        xyz = localisation.cloud_from_disparity(disp, cam.fx, cam.fy, cam.cx, cam.cy, baseline)
        packed = np.zeros((cam.height, cam.width, 8), np.float32)
        packed[:, :, :3] = xyz
        raw = packed.tobytes()
        dets = det.detect(right)
        P = cam.P(-cam.fx * baseline).flatten().tolist()

        def decode_locate():
            c = localisation.cloud_array(raw, cam.height, cam.width, 32, 32 * cam.width,
                                         (0, 4, 8))
            for d in dets:
                localisation.locate(c, d, P, image=right)
        out['image_processing: points2 decode + locate (%d fruit)' % len(dets)] = \
            _median_ms(decode_locate, repeat)
    except ImportError as exc:
        out['vision stages'] = 'skipped (%s)' % exc
    try:
        import rospy
        import tf2_py
        from geometry_msgs.msg import TransformStamped
        buf = tf2_py.BufferCore(rospy.Duration(60.0))
        for k in range(200):
            for parent, child in (('map', 'base_link'), ('base_link', 'stereo_left_optical')):
                t = TransformStamped()
                t.header.stamp = rospy.Time(100.0 + 0.05 * k)
                t.header.frame_id, t.child_frame_id = parent, child
                t.transform.rotation.w = 1.0
                buf.set_transform(t, 'bench')
        out['tf2 lookup (2 frames, interpolated), per call'] = _median_ms(
            lambda: buf.lookup_transform_core('map', 'stereo_left_optical',
                                              rospy.Time(105.025)),
            repeat * 50)
    except ImportError as exc:
        out['tf'] = 'skipped (%s)' % exc
    return out


def _cpu_by_node(root_pid):
    """{node name: CPU seconds} of every process below root_pid (from /proc)."""
    tick = os.sysconf('SC_CLK_TCK')
    parents, out = {}, {}
    for pid in os.listdir('/proc'):
        if not pid.isdigit():
            continue
        try:
            with open('/proc/%s/stat' % pid) as f:
                fields = f.read().rsplit(')', 1)[1].split()
            with open('/proc/%s/cmdline' % pid, 'rb') as f:
                cmd = f.read().split(b'\0')
        except (IOError, OSError):
            continue
        parents[int(pid)] = (int(fields[1]), (int(fields[11]) + int(fields[12])) / tick, cmd)
    for pid, (ppid, cpu, cmd) in parents.items():
        p, ok = ppid, pid == root_pid
        while not ok and p in parents and p > 1:
            if p == root_pid:
                ok = True
                break
            p = parents[p][0]
        if not ok:
            continue
        name = [c.decode()[8:] for c in cmd if c.startswith(b'__name:=')]
        if name:
            key = name[0]
        elif b'roslaunch' in b' '.join(cmd[:3]):
            key = 'roslaunch'
        elif b'rosmaster' in b' '.join(cmd[:3]):
            key = 'rosmaster'
        else:
            key = os.path.basename(cmd[0].decode() if cmd[0] else str(pid))
        out[key] = out.get(key, 0.0) + cpu
    return out


# ---------------------------------------------------------------------- whole-stack runs
def stack_run(scenario_name, time_scale, wall_limit, profile, launch_args):
    """One mission of sim.launch on a private master, measured from this process. Runs in a
    child process (rospy cannot change masters); returns a dict."""
    cmd = [sys.executable, '-c', 'import sys, json; from harvest_sim import bench; '
           'print("RESULT " + json.dumps(bench._stack_run_here(*json.loads(sys.argv[1]))))',
           json.dumps([scenario_name, time_scale, wall_limit, profile, list(launch_args)])]
    out = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         universal_newlines=True)
    for line in out.stdout.splitlines():
        if line.startswith('RESULT '):
            return json.loads(line[7:])
    return {'error': 'the run printed no result: ' + out.stdout[-800:]}


def _stack_run_here(scenario_name, time_scale, wall_limit, profile, launch_args):
    port = instance.free_port()
    master = 'http://127.0.0.1:%d' % port
    os.environ.update({'ROS_MASTER_URI': master, 'ROS_HOSTNAME': 'localhost'})
    workdir = tempfile.mkdtemp(prefix='bench_sim_')
    log_path = os.path.join(workdir, 'launch.log')
    log = open(log_path, 'w')
    procs = []
    try:
        procs.append(subprocess.Popen(['roscore', '-p', str(port)], stdout=log,
                                      stderr=subprocess.STDOUT, start_new_session=True))
        import rosgraph
        deadline = time.time() + 30
        while not rosgraph.is_master_online(master):
            if time.time() > deadline:
                raise RuntimeError('roscore did not come up')
            wallsleep(0.1)
        if profile:
            rosgraph.Master('/bench_sim').setParam('/enable_statistics', True)
            rosgraph.Master('/bench_sim').setParam('/statistics_window_max_size', 5)
        wall0 = time.time()
        launch = subprocess.Popen(
            ['roslaunch', 'harvest_bringup', 'sim.launch', 'scenario:=%s' % scenario_name,
             'time_scale:=%g' % time_scale] + instance.sim_launch_args() + [
             'db_path:=%s' % os.path.join(workdir, 'bench.db'),
             'mission_id:=bench-%s-%g' % (scenario_name, time_scale)] + list(launch_args),
            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        procs.append(launch)
        res = _measure_mission(launch, wall0, wall_limit, profile)
        res['log'] = log_path
        return res
    except RuntimeError as exc:
        return {'error': '%s (log %s)' % (exc, log_path)}
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGINT)
                try:
                    p.wait(30)
                except subprocess.TimeoutExpired:
                    os.killpg(p.pid, signal.SIGKILL)
        log.close()


def _measure_mission(launch, wall0, wall_limit, profile):
    import rospy
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import String
    rospy.init_node('bench_sim', disable_signals=True)
    lock = threading.Lock()
    st = {'first': None, 'last': None, 'summary': None, 'frames': {},
          'split': {'fast': 0.0, 'rest': 0.0, 'held': 0.0}}
    done = threading.Event()

    def on_clock(msg):
        with lock:
            now = (time.time(), msg.clock.to_sec())
            if st['first'] is None:
                st['first'] = now
            elif st['summary'] is None:
                # where the wall time goes: fast ticks (something moves), ticks at about real
                # time (the world rests: the robot starts or thinks), long gaps (a camera holds)
                dw, ds = now[0] - st['last'][0], now[1] - st['last'][1]
                kind = 'fast' if ds > 1.5 * dw else ('held' if dw > 3.0 * ds else 'rest')
                st['split'][kind] += dw
            st['last'] = now

    def on_summary(msg):
        with lock:
            st['summary'] = json.loads(msg.data)
            st['end'] = st['last']
        done.set()

    def on_stats(msg):
        with lock:
            key = (msg.topic, msg.node_sub)
            st['frames'][key] = st['frames'].get(key, 0) + msg.delivered_msgs

    rospy.Subscriber('/clock', Clock, on_clock, queue_size=50)
    rospy.Subscriber('/mission/summary', String, on_summary)
    if profile:
        from rosgraph_msgs.msg import TopicStatistics
        rospy.Subscriber('/statistics', TopicStatistics, on_stats, queue_size=500)
    cpu0 = None
    while not done.wait(0.5):
        if launch.poll() is not None:
            raise RuntimeError('the launch ended before the mission did')
        if time.time() - wall0 > wall_limit:
            raise RuntimeError('no mission summary within %.0f s wall' % wall_limit)
        if cpu0 is None and st['first'] is not None:
            cpu0 = (time.time(), _cpu_by_node(launch.pid))
    cpu1 = (time.time(), _cpu_by_node(launch.pid))
    with lock:
        first, end, summary = st['first'], st['end'], st['summary']
        split = dict(st['split'])
    res = {'summary': summary, 'wall': end[0] - first[0], 'sim': end[1] - first[1],
           'wall_total': end[0] - wall0, 'split': split}
    res['speed'] = res['sim'] / res['wall'] if res['wall'] > 0 else 0.0
    from harvest_sim.srv import GetSimSummary
    try:
        rospy.wait_for_service('/sim/get_summary', timeout=10.0)
        t = rospy.ServiceProxy('/sim/get_summary', GetSimSummary)()
        res['truth'] = {'ripe_reachable': t.ripe_reachable, 'collected': t.collected,
                        'dropped': t.dropped, 'damaged': t.damaged}
    except (rospy.ROSException, rospy.ServiceException) as exc:
        res['truth'] = {'error': str(exc)}
    if cpu0 is not None:
        span = cpu1[0] - cpu0[0]
        res['cpu_span'] = span
        res['cpu'] = dict((k, (v - cpu0[1].get(k, 0.0)) / span * 100.0)
                          for k, v in cpu1[1].items())
    if profile:
        wallsleep(1.0)      # the last statistics windows
        with lock:
            res['frames'] = dict(('%s|%s' % k, v) for k, v in st['frames'].items())
    rospy.signal_shutdown('bench done')
    return res


def _frames(frames, topic_suffixes, sub=None):
    """Most frames delivered on a topic ending with one of topic_suffixes (to sub if given)."""
    best = 0
    for key, n in frames.items():
        topic, node = key.split('|', 1)
        if any(topic.endswith(s) for s in topic_suffixes) and (sub is None or sub in node):
            best = max(best, n)
    return best


FRAME_TOPICS = {'stereo': ('left/image_raw',), 'hand': ('hand_eye/image_raw',
                                                        'hand_camera/image_raw'),
                'points2': ('points2',)}


def print_profile(res, scale):
    cpu, frames = res.get('cpu', {}), res.get('frames', {})
    span, sim = res.get('cpu_span', 0.0), res.get('sim', 0.0)
    print('profile at time scale %g (%s): %.0f s wall, %.0f s sim; CPU %% of one core over the '
          'mission; frames per simulated second; CPU ms per frame' % (
              scale, res.get('summary', {}).get('mission_id', ''), span, sim))
    print('| stage | nodes | CPU % | frames / sim s | CPU ms / frame |')
    print('|---|---|---:|---:|---:|')
    counted = set()
    for label, nodes, kind in PROFILE_ROWS:
        share = sum(cpu.get(n, 0.0) for n in nodes)
        counted.update(nodes)
        if kind:
            n = _frames(frames, FRAME_TOPICS[kind])
            rate = '%.2f' % (n / sim) if sim > 0 else '-'
            ms = '%.0f' % (share / 100.0 * span * 1000.0 / n) if n else '-'
        else:
            rate, ms = '-', '-'
        print('| %s | %s | %.0f | %s | %s |' % (label, ', '.join(nodes), share, rate, ms))
    rest = sorted(((k, v) for k, v in cpu.items() if k not in counted and v >= 0.5),
                  key=lambda kv: -kv[1])
    print('| other | %s | %.0f | - | - |' % (', '.join('%s %.0f' % kv for kv in rest),
                                             sum(v for _, v in rest)))
    print('| total | | %.0f | | |' % sum(cpu.values()))


def run_line(scale, res):
    if 'error' in res:
        return 'time scale %g: FAILED: %s' % (scale, res['error'])
    s, truth = res['summary'], res.get('truth', {})
    cycle = s.get('mean_cycle_time')
    cycle = 'n/a' if cycle is None or (isinstance(cycle, float) and math.isnan(cycle)) \
        else '%.1f' % cycle
    split = res.get('split', {})
    return ('time scale %g: speed reached %.2f (%.0f s sim in %.1f s wall: %.1f s moving, %.1f s '
            'at rest, %.1f s held by cameras; launch to summary %.1f s); mission %s, picked %s '
            'of %s ripe reachable (truth: collected %s, dropped %s, damaged %s), mean cycle %s '
            's/fruit (sim)' % (
                scale, res['speed'], res['sim'], res['wall'], split.get('fast', 0.0),
                split.get('rest', 0.0), split.get('held', 0.0), res['wall_total'],
                s['outcome'], s['picked'], truth.get('ripe_reachable', '?'),
                truth.get('collected', '?'), truth.get('dropped', '?'),
                truth.get('damaged', '?'), cycle))


# ---------------------------------------------------------------------- simulator alone
def live_run(scenario_name, seconds, time_scale, controller):
    port = instance.free_port()
    env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % port)
    os.environ['ROS_MASTER_URI'] = env['ROS_MASTER_URI']
    procs = []
    devnull = open(os.devnull, 'w')
    try:
        procs.append(subprocess.Popen(['roscore', '-p', str(port)], env=env, stdout=devnull,
                                      stderr=devnull))
        import rosgraph
        master = rosgraph.Master('/bench_sim')
        deadline = time.time() + 20
        while not master.is_online():
            if time.time() > deadline:
                raise RuntimeError('roscore did not come up')
            wallsleep(0.2)
        launch = subprocess.Popen(
            ['roslaunch', 'harvest_sim', 'sim_robot.launch', 'scenario:=' + scenario_name,
             'time_scale:=%g' % time_scale, 'controller:=%s' % str(controller).lower(),
             'modbus_port:=%d' % instance.free_port(),
             'controller_serial:=%d' % instance.new_serial_number()],
            env=env, stdout=devnull, stderr=devnull)
        procs.append(launch)
        return _measure(seconds, controller, launch.pid)
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
                try:
                    p.wait(20)
                except subprocess.TimeoutExpired:
                    p.kill()
        devnull.close()


def _measure(seconds, controller, launch_pid):
    import rospy
    from rosgraph_msgs.msg import Clock
    from sensor_msgs.msg import Image, JointState, PointCloud2
    rospy.init_node('bench_sim', disable_signals=True)
    lock = threading.Lock()
    counts = {'stereo': [], 'hand': [], 'points2': []}
    clock = []

    def counter(key):
        def cb(msg):
            with lock:
                counts[key].append((time.time(), msg.header.stamp.to_sec()))
        return cb

    def on_clock(msg):
        with lock:
            clock.append((time.time(), msg.clock.to_sec()))

    rospy.Subscriber('/clock', Clock, on_clock, queue_size=100)
    subs = [rospy.Subscriber('bumblebee2/left/image_raw', Image, counter('stereo'),
                             queue_size=1, buff_size=1 << 24),
            rospy.Subscriber('hand_camera/image_raw', Image, counter('hand'), queue_size=1,
                             buff_size=1 << 24),
            rospy.Subscriber('bumblebee2/points2', PointCloud2, counter('points2'),
                             queue_size=1, buff_size=1 << 24)]
    move = None
    if not controller:
        pub = rospy.Publisher('/sim/joint_states', JointState, queue_size=5)

        def move(_event):
            t = rospy.get_time()
            names = ['cart_joint', 'waist_joint', 'left_lift_joint', 'left_boom_joint',
                     'left_forearm_joint', 'right_lift_joint', 'right_boom_joint',
                     'right_forearm_joint']
            q = [0.75 + 0.25 * math.sin(t / 4.0), 0.0, 0.15 + 0.1 * math.sin(t), -0.3,
                 -0.6, 0.0, -0.785, -2.356]
            msg = JointState(name=names, position=q)
            msg.header.stamp = rospy.Time.now()
            pub.publish(msg)
    deadline = time.time() + 60
    while time.time() < deadline:
        with lock:
            ready = len(clock) > 10 and counts['stereo'] and counts['hand']
        if ready:
            break
        wallsleep(0.2)
    phases = [('still', None)] if controller else [('still', None), ('moving', move)]
    results = []
    for name, callback in phases:
        timer = rospy.Timer(rospy.Duration(1.0 / 20.0), callback) if callback else None
        wallsleep(2.0)                                # warm-up
        with lock:
            start = (time.time(), clock[-1][1], dict((k, len(v)) for k, v in counts.items()))
        cpu0 = _cpu_by_node(launch_pid)
        wallsleep(seconds / len(phases))
        cpu1 = _cpu_by_node(launch_pid)
        with lock:
            end = (time.time(), clock[-1][1], dict((k, len(v)) for k, v in counts.items()))
        if timer is not None:
            timer.shutdown()
        wall, sim = end[0] - start[0], end[1] - start[1]
        rates = dict((k, (end[2][k] - start[2][k]) / sim if sim > 0 else 0.0) for k in counts)
        cpu = dict((k, (cpu1.get(k, 0.0) - cpu0.get(k, 0.0)) / wall * 100) for k in cpu1)
        results.append({'phase': name, 'wall': wall, 'sim': sim, 'scale': sim / wall,
                        'rates': rates, 'cpu': cpu})
    for s in subs:
        s.unregister()
    rospy.signal_shutdown('bench done')
    return results


def main(argv=None):
    p = argparse.ArgumentParser(description='Simulator benchmark (prints figures).')
    p.add_argument('--scenario', default='default', help='scenario of the whole-stack runs')
    p.add_argument('--scales', default='2,5,10,20',
                   help='time scales of the whole-stack runs (comma separated; "" for none)')
    p.add_argument('--wall-limit', type=float, default=600.0,
                   help='wall seconds per whole-stack run')
    p.add_argument('--profile', action='store_true',
                   help='stage costs in this process and the per-node table of one run')
    p.add_argument('--profile-scale', type=float, default=5.0)
    p.add_argument('--launch-arg', action='append', default=[],
                   help='extra sim.launch argument NAME:=VALUE (repeatable)')
    p.add_argument('--frames', type=int, default=10, help='frames per camera for render cost')
    p.add_argument('--render-scenario', default='three_targets')
    p.add_argument('--no-render', action='store_true', help='skip the render cost')
    p.add_argument('--save-image', default=None, help='write the first left stereo frame here')
    p.add_argument('--sim-only', action='store_true',
                   help='live run of sim_robot.launch alone (robot still, then moving)')
    p.add_argument('--seconds', type=float, default=20.0, help='wall seconds of --sim-only')
    p.add_argument('--time-scale', type=float, default=5.0, help='time scale of --sim-only')
    p.add_argument('--controller', action='store_true',
                   help='--sim-only: the simulated Modbus controller instead of moving joints')
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    print('machine: %d CPU cores, load average %.2f %.2f %.2f (shared machine: other jobs '
          'inflate these figures)' % ((os.cpu_count() or 0,) + os.getloadavg()))
    sys.stdout.flush()
    if not args.no_render:
        r = render_cost(args.render_scenario, args.frames, args.save_image)
        print('render (%s): renderer set-up %.0f ms; new view, stereo eye 1024x768: mean '
              '%.1f ms, median %.1f ms; hand 640x480: mean %.1f ms, median %.1f ms; still '
              'scene (cached), stereo eye: median %.1f ms'
              % (args.render_scenario, r['init_ms'], np.mean(r['stereo_ms']),
                 np.median(r['stereo_ms']), np.mean(r['hand_ms']), np.median(r['hand_ms']),
                 r['cached_ms']))
        if args.save_image:
            print('saved %s' % args.save_image)
    if args.profile:
        print('stage costs, median ms in this process (%s):' % args.render_scenario)
        for k, v in stage_costs(args.render_scenario).items():
            print('  %-58s %s' % (k, ('%.2f' % v) if isinstance(v, float) else v))
    sys.stdout.flush()
    if args.sim_only:
        for res in live_run(args.render_scenario, args.seconds, args.time_scale,
                            args.controller):
            what = {'still': 'robot still', 'moving': 'cart and left arm moving'}[res['phase']]
            print('sim only, %s (time_scale %.1f): %.1f s simulated in %.1f s wall -> %.2f'
                  % (what, args.time_scale, res['sim'], res['wall'], res['scale']))
            print('  frames per simulated second: stereo pairs %.2f, hand %.2f, points2 %.2f'
                  % (res['rates']['stereo'], res['rates']['hand'], res['rates']['points2']))
            print('  CPU %% of one core: ' + ', '.join(
                '%s %.0f' % (k, v) for k, v in sorted(res['cpu'].items(), key=lambda kv: -kv[1])
                if v >= 0.5))
        return 0
    scales = [float(x) for x in args.scales.split(',') if x.strip()]
    if args.profile and args.profile_scale not in scales:
        scales.append(args.profile_scale)
    print('whole stack (harvest_bringup sim.launch, scenario %s), one mission per time scale:'
          % args.scenario)
    sys.stdout.flush()
    ok = True
    for scale in scales:
        profile = args.profile and scale == args.profile_scale
        res = stack_run(args.scenario, scale, args.wall_limit, profile, args.launch_arg)
        print(run_line(scale, res) + '  [load %.2f]' % os.getloadavg()[0])
        if profile and 'error' not in res:
            print_profile(res, scale)
        ok = ok and 'error' not in res and res['summary'].get('outcome') == 'succeeded'
        sys.stdout.flush()
    return 0 if ok else 1
