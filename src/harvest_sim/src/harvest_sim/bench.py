"""Benchmark of the simulator (scripts/bench_sim): render cost and achieved time scale.

1. Render cost, in this process: full re-renders of the stereo pair and the hand camera on a
   scenario (the pose changes every frame, so no cache helps).
2. Live run: a private roscore on a free port, sim_robot.launch (clock, world, both cameras,
   stereo_image_proc; by default without the Modbus controller) with this process subscribing
   to both cameras and points2, in two phases: robot still (cached frames republished), then
   this process as a fake controller moving the cart and the left arm all the time (worst
   case: every camera frame is rendered anew). Prints per phase the achieved time scale
   (simulated / wall seconds), frames per simulated second and the CPU share of every node.
This is a tool, not a node: it waits in wall time (rospy.rostime.wallsleep) and reads /proc.
"""

import argparse
import math
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
from rospy.rostime import wallsleep  # wall time on purpose: the harness measures sim vs wall time


def _paths():
    here = os.path.dirname(os.path.abspath(__file__))
    pkg = os.path.normpath(os.path.join(here, '..', '..'))
    try:
        import rospkg
        rp = rospkg.RosPack()
        return rp.get_path('harvest_sim'), os.path.join(rp.get_path('visualization_pkg'),
                                                        'config', 'robot.yaml')
    except Exception:      # noqa: BLE001 - no ROS environment: source tree
        return pkg, os.path.join(pkg, '..', 'visualization_pkg', 'config', 'robot.yaml')


def render_cost(scenario_name, frames, save_image=None):
    """Mean / median ms per stereo eye frame and per hand frame (full re-render each time)."""
    from harvest_sim import camera_model, render, scenario as scn
    from motion_pkg.kinematics import RobotGeometry
    pkg, robot = _paths()
    geom = RobotGeometry.from_yaml(robot)
    s = scn.load_scenario(scn.resolve_scenario(scenario_name, os.path.join(pkg, 'scenarios')))
    t0 = time.perf_counter()
    r = render.Renderer(s)
    init_ms = (time.perf_counter() - t0) * 1000
    fr = render.fruits_from_scenario(s)
    stereo, hand = camera_model.stereo_camera(), camera_model.hand_camera()
    y0 = s.track.picking_points[0]
    ik = geom.inverse('left', (0.5, y0 * 0 + 0.0, 1.0))
    res = {'init_ms': init_ms, 'stereo_ms': [], 'hand_ms': []}
    r.render(stereo, geom.frame_transforms({'cart_joint': y0})['stereo_left_optical'], fr,
             ('left', 0))                                 # warm caches (rays, noise bank)
    for i in range(frames):
        poses = geom.frame_transforms({'cart_joint': y0 + 0.002 * i,
                                       'left_lift_joint': ik.joints[0] + 0.001 * i,
                                       'left_boom_joint': ik.joints[1],
                                       'left_forearm_joint': ik.joints[2]})
        for eye in ('stereo_left_optical', 'stereo_right_optical'):
            t = time.perf_counter()
            img = r.render(stereo, poses[eye], fr, (eye, i))
            res['stereo_ms'].append((time.perf_counter() - t) * 1000)
            if save_image and i == 0 and eye == 'stereo_left_optical':
                import cv2
                first = r.render(stereo, geom.frame_transforms({'cart_joint': y0})[eye], fr,
                                 ('left', 0))
                cv2.imwrite(save_image, first)
        t = time.perf_counter()
        r.render(hand, poses['hand_camera_optical'], fr, ('hand', i))
        res['hand_ms'].append((time.perf_counter() - t) * 1000)
    del img
    return res


def _free_port():
    s = socket.socket()
    s.bind(('127.0.0.1', 0))
    port = s.getsockname()[1]
    s.close()
    return port


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
        p, ok = ppid, False
        while p in parents and p > 1:
            if p == root_pid:
                ok = True
                break
            p = parents[p][0]
        if not ok:
            continue
        name = [c.decode()[8:] for c in cmd if c.startswith(b'__name:=')]
        key = name[0] if name else os.path.basename(cmd[0].decode() if cmd[0] else str(pid))
        out[key] = out.get(key, 0.0) + cpu
    return out


def live_run(scenario_name, seconds, time_scale, controller):
    port = _free_port()
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
             'time_scale:=%g' % time_scale, 'controller:=%s' % str(controller).lower()],
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
        timer = rospy.Timer(rospy.Duration(1.0 / 60.0), callback) if callback else None
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
    p.add_argument('--scenario', default='three_targets')
    p.add_argument('--frames', type=int, default=10, help='frames per camera for render cost')
    p.add_argument('--seconds', type=float, default=20.0, help='wall seconds of the live run')
    p.add_argument('--time-scale', type=float, default=5.0)
    p.add_argument('--controller', action='store_true',
                   help='run the simulated Modbus controller instead of fake moving joints')
    p.add_argument('--no-live', action='store_true', help='render cost only')
    p.add_argument('--save-image', default=None, help='write the first left stereo frame here')
    args = p.parse_args(sys.argv[1:] if argv is None else argv)
    print('machine: %d CPU cores, load average %.2f %.2f %.2f (shared machine: other jobs '
          'inflate these figures)' % ((os.cpu_count() or 0,) + os.getloadavg()))
    r = render_cost(args.scenario, args.frames, args.save_image)
    print('render (%s): renderer set-up %.0f ms; stereo eye frame 1024x768: mean %.1f ms, '
          'median %.1f ms (pair %.0f ms); hand frame 640x480: mean %.1f ms, median %.1f ms'
          % (args.scenario, r['init_ms'], np.mean(r['stereo_ms']), np.median(r['stereo_ms']),
             2 * np.mean(r['stereo_ms']), np.mean(r['hand_ms']), np.median(r['hand_ms'])))
    if args.save_image:
        print('saved %s' % args.save_image)
    if args.no_live:
        return 0
    for res in live_run(args.scenario, args.seconds, args.time_scale, args.controller):
        what = {'still': 'robot still: cached frames republished',
                'moving': 'cart and left arm moving: every frame rendered anew'}[res['phase']]
        print('live %s (%s, time_scale %.1f): %.1f s simulated in %.1f s wall -> achieved '
              'time scale %.2f (goal >= 5)' % (what, args.scenario, args.time_scale,
                                               res['sim'], res['wall'], res['scale']))
        print('  frames per simulated second: stereo pairs %.2f, hand %.2f, points2 %.2f'
              % (res['rates']['stereo'], res['rates']['hand'], res['rates']['points2']))
        print('  CPU % of one core: ' + ', '.join(
            '%s %.0f' % (k, v) for k, v in sorted(res['cpu'].items(), key=lambda kv: -kv[1])
            if v >= 0.5))
    return 0
