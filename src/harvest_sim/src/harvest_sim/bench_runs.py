"""Benchmark of the simulator (bench_sim), measured on launched stacks: one whole mission of
harvest_bringup sim.launch per time scale on a private master (stack_run), or the older live run of
sim_robot.launch alone (live_run, --sim-only); the CPU of every node from /proc. Re-exported by
harvest_sim.bench. This waits in wall time (rospy.rostime.wallsleep) and reads /proc.
"""

import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time

from rospy.rostime import wallsleep  # wall time on purpose: the harness measures sim vs wall time

from harvest_sim import instance


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
    cmd = [sys.executable, '-c', 'import sys, json; from harvest_sim import bench_runs; print('
           '"RESULT " + json.dumps(bench_runs._stack_run_here(*json.loads(sys.argv[1]))))',
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
    from harvest_sim.truth import ground_truth_counts, wait_fruits_at_rest
    try:
        # the last fruit can still be on its way into the box when the summary comes
        wait_fruits_at_rest(launch)
        rospy.wait_for_service('/sim/get_summary', timeout=10.0)
        t = rospy.ServiceProxy('/sim/get_summary', GetSimSummary)()
        ripe_reachable, harvested, _ = ground_truth_counts(t)
        res['truth'] = {'ripe_reachable': ripe_reachable, 'harvested': harvested,
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
