"""Emergency-stop latency of the simulated robot: command -> halt on the Modbus wire -> at rest.

Starts `harvest_bringup sim.launch` (a private master, a free controller port and a serial
number of its own: harvest_sim.instance, through tools/run_demo.py's helpers) and, at random
moments of the mission, sends the stop command, alternately on the topic `emergency_stop`
(std_msgs/Bool true) and through the service `task_planner/emergency_stop`, then measures

  (a) command -> the first Modbus write that halts axes, as the simulated controller saw it
      (`/sim/sim_controller/halt_received`: the write's wall time, time.time(), and ROS time);
  (b) command -> the first simulated joint state (/sim/joint_states) stamped at or after that
      halt with every velocity zero: all axes at rest,

in wall ms (time.time() here and in the controller, one machine) and in simulated ms (the ROS
time of the halt or joint state minus this node's ROS time at the command), then resumes
(`task_planner/resume`) and goes on; a mission that ends is started again until `--trials`
stops are measured (`--while-moving`: each stop waits for an axis to move). Prints median, p95, p99 and max of each; `--load` runs two
`stress-ng --cpu 1` hogs beside it. Run it with tools/ws_run.sh:

  tools/ws_run.sh tools/bench_estop.py [--trials 100] [--load] [--scenario default]
"""
import argparse
import json
import os
import random
import subprocess
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from run_demo import DEFAULT_TIME_SCALE, fatal_lines, stop_launch  # noqa: E402

#: wall seconds a trial waits for the halt, for the rest, for the resume
HALT_WAIT, REST_WAIT, RESUME_WAIT = 5.0, 10.0, 10.0
TARGET_P99_MS = 50.0


def percentiles(values):
    """(median, p95, p99, max) of a list of numbers (linear interpolation), or None."""
    if not values:
        return None
    v = sorted(values)

    def pct(p):
        k = (len(v) - 1) * p / 100.0
        lo = int(k)
        hi = min(lo + 1, len(v) - 1)
        return v[lo] + (v[hi] - v[lo]) * (k - lo)
    return pct(50), pct(95), pct(99), v[-1]


class Probe(object):
    """This benchmark's node: the halt events, the joint states and the mission's events."""

    def __init__(self):
        import rospy
        from harvest_msgs.msg import MissionEvent
        from sensor_msgs.msg import JointState, TimeReference
        from std_msgs.msg import Bool, String
        from std_srvs.srv import Trigger
        self.rospy = rospy
        self.cond = threading.Condition()
        self.halts = []             # (wall of the write, ROS time of the write, what)
        self.rest = []              # (wall received, stamp) of joint states with all at rest
        self.moving = False         # latest joint state has a velocity
        self.events = []            # (kind, state)
        self.done = False
        self.outcome = None         # the mission's outcome, from its summary
        rospy.Subscriber('/sim/sim_controller/halt_received', TimeReference, self._on_halt,
                         queue_size=50, tcp_nodelay=True)
        rospy.Subscriber('/sim/joint_states', JointState, self._on_joints, queue_size=50,
                         tcp_nodelay=True)
        rospy.Subscriber('/mission/events', MissionEvent, self._on_event, queue_size=100)
        rospy.Subscriber('/mission/summary', String, self._on_summary, queue_size=1)
        self.state = ''
        rospy.Subscriber('/task_planner/state', String, self._on_state, queue_size=10)
        self.estop_pub = rospy.Publisher('/emergency_stop', Bool, queue_size=1, tcp_nodelay=True)
        self.estop_srv = rospy.ServiceProxy('/task_planner/emergency_stop', Trigger,
                                            persistent=True)
        self.resume_srv = rospy.ServiceProxy('/task_planner/resume', Trigger)
        self.bool_true = Bool(data=True)

    def _on_halt(self, msg):
        with self.cond:
            self.halts.append((msg.time_ref.to_sec(), msg.header.stamp.to_sec(), msg.source))
            self.cond.notify_all()

    def _on_joints(self, msg):
        wall = time.time()
        moving = any(abs(v) > 0.0 for v in msg.velocity)
        with self.cond:
            started = moving and not self.moving
            self.moving = moving
            if not moving:
                self.rest.append((wall, msg.header.stamp.to_sec()))
                del self.rest[:-200]
            if started or not moving:
                self.cond.notify_all()

    def _on_event(self, msg):
        with self.cond:
            self.events.append((msg.kind, msg.state))
            self.cond.notify_all()

    def _on_state(self, msg):
        with self.cond:
            self.state = msg.data
            self.cond.notify_all()

    def started(self):
        """The mission is past its start-up self-test (DO_START passed)."""
        return (any(s in ('DO_START', 'NEXT_POINT') for k, s in self.events if k == 'state') or
                bool(self.state) and not self.state.startswith('START'))

    def _on_summary(self, msg):
        with self.cond:
            try:
                self.outcome = json.loads(msg.data).get('outcome')
            except ValueError:
                self.outcome = 'unreadable summary'
            self.done = True
            self.cond.notify_all()

    def wait_for(self, predicate, timeout):
        deadline = time.time() + timeout
        with self.cond:
            while True:
                got = predicate()
                if got or self.rospy.is_shutdown():
                    return got
                left = deadline - time.time()
                if left <= 0.0:
                    return got
                self.cond.wait(min(left, 0.5))

    def trial(self, use_topic):
        """One stop: returns a result dict, or None when the mission ended first."""
        with self.cond:
            if self.done:
                return None
            n_events = len(self.events)
            moving = self.moving
        sim0 = self.rospy.get_time()
        t0 = time.time()
        if use_topic:
            self.estop_pub.publish(self.bool_true)
        else:
            self.estop_srv()
        halt = self.wait_for(lambda: next((h for h in self.halts if h[0] >= t0), None), HALT_WAIT)
        result = {'via': 'topic' if use_topic else 'service', 'moving': moving, 'wall': t0}
        if halt is None:
            result['error'] = 'no halt within %.0f s' % HALT_WAIT
        else:
            result.update(halt_wall_ms=(halt[0] - t0) * 1000.0, halt_sim_ms=(halt[1] - sim0) * 1000.0,
                          halt_what=halt[2])
            # the first joint state at rest received after the halt write, stamped at or after it
            rest = self.wait_for(lambda: next((r for r in self.rest
                                               if r[1] >= halt[1] and r[0] >= halt[0]), None),
                                 REST_WAIT)
            if rest is None:
                result['error'] = 'not at rest within %.0f s' % REST_WAIT
            else:
                result.update(rest_wall_ms=(rest[0] - t0) * 1000.0,
                              rest_sim_ms=(rest[1] - sim0) * 1000.0)
        # the executive is in DO_STOP once it published its estop event: resume
        self.wait_for(lambda: any(k == 'estop' for k, _ in self.events[n_events:]), RESUME_WAIT)
        try:
            self.resume_srv.wait_for_service(timeout=5.0)
            self.resume_srv()
        except (self.rospy.ROSException, self.rospy.ServiceException) as exc:
            result['error'] = result.get('error', '') + ' resume failed: %s' % exc
        self.wait_for(lambda: any(k == 'resume' for k, _ in self.events[n_events:]) or self.done,
                      RESUME_WAIT)
        with self.cond:
            self.halts = [h for h in self.halts if h[0] >= t0]
        return result


def worker(args):
    """One launch: up to args.trials stops until the mission ends; results to args.out (JSON)."""
    import rosgraph
    from harvest_sim.instance import free_port, sim_launch_args
    port = free_port()
    master = 'http://127.0.0.1:%d' % port
    env = dict(os.environ, ROS_MASTER_URI=master, ROS_HOSTNAME='localhost')
    os.environ.update({'ROS_MASTER_URI': master, 'ROS_HOSTNAME': 'localhost'})
    results, status = [], 'ok'
    log = open(args.log, 'w')
    launch = subprocess.Popen(
        ['roslaunch', '-p', str(port), 'harvest_bringup', 'sim.launch',
         'scenario:=%s' % args.scenario, 'time_scale:=%g' % args.time_scale,
         'db_path:=%s' % os.path.join(tempfile.gettempdir(), 'bench_estop_%d.db' % os.getpid()),
         'mission_id:=estop-%s' % args.scenario] + sim_launch_args(),
        stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    try:
        deadline = time.time() + 60.0
        while not rosgraph.is_master_online(master) or \
                not rosgraph.Master('/bench_estop').hasParam('/use_sim_time'):
            if time.time() > deadline or launch.poll() is not None:
                raise RuntimeError('the launch did not come up; see %s' % args.log)
            time.sleep(0.1)   # harness polling the master from outside ROS; not node code
        import rospy
        rospy.init_node('bench_estop', anonymous=True, disable_signals=True)
        probe = Probe()
        # stops during the mission, not during the start-up self-test
        if not probe.wait_for(probe.started, 120.0):
            raise RuntimeError('the mission did not start within 120 s; see %s' % args.log)
        if not probe.wait_for(lambda: probe.estop_pub.get_num_connections() > 0, 10.0):
            raise RuntimeError('nobody subscribes to /emergency_stop')
        rng = random.Random(args.seed)
        for i in range(args.trials):
            if probe.wait_for(lambda: probe.done, rng.uniform(args.min_gap, args.max_gap)):
                break
            if launch.poll() is not None:
                raise RuntimeError('the launch ended%s; see %s' % (
                    ''.join(': ' + line for line in fatal_lines(args.log)), args.log))
            if args.while_moving and not probe.wait_for(lambda: probe.moving or probe.done, 60.0):
                raise RuntimeError('no axis moved within 60 s')
            got = probe.trial(use_topic=(args.first + i) % 2 == 0)
            if got is None:
                break
            results.append(got)
        if probe.done:
            status = 'the mission ended %s' % probe.outcome
    except RuntimeError as exc:
        status = str(exc)
    finally:
        stop_launch(launch)
        log.close()
    with open(args.out, 'w') as stream:
        json.dump({'status': status, 'results': results}, stream)
    return 0


def start_hogs():
    return [subprocess.Popen(['stress-ng', '--cpu', '1', '--quiet'], start_new_session=True,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            for _ in range(2)]


def stop_hogs(hogs):
    import signal
    for hog in hogs:
        try:
            os.killpg(hog.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
        hog.wait()


def report(results, load):
    good = [r for r in results if 'error' not in r]
    print('%d stops (%d while moving), %d failed%s' % (
        len(results), sum(1 for r in results if r['moving']), len(results) - len(good),
        ' beside two stress-ng --cpu 1 hogs' if load else ' without load'))
    for r in results:
        if 'error' in r:
            print('  failed (%s): %s' % (r['via'], r['error']))
    print('%-34s %8s %8s %8s %8s' % ('ms', 'median', 'p95', 'p99', 'max'))
    rows = [('(a) command -> halt write, wall', 'halt_wall_ms', good),
            ('(a) command -> halt write, sim', 'halt_sim_ms', good),
            ('(b) command -> at rest, wall', 'rest_wall_ms', [r for r in good if 'rest_wall_ms' in r]),
            ('(b) command -> at rest, sim', 'rest_sim_ms', [r for r in good if 'rest_sim_ms' in r]),
            ('(b) while moving, wall', 'rest_wall_ms', [r for r in good if r['moving'] and 'rest_wall_ms' in r]),
            ('(b) while moving, sim', 'rest_sim_ms', [r for r in good if r['moving'] and 'rest_sim_ms' in r])]
    for via in ('topic', 'service'):
        rows.append(('(a) via %s, wall' % via, 'halt_wall_ms', [r for r in good if r['via'] == via]))
    for label, key, rs in rows:
        stats = percentiles([r[key] for r in rs])
        if stats:
            print('%-34s %8.1f %8.1f %8.1f %8.1f' % ((label,) + stats))
    stats = percentiles([r['halt_wall_ms'] for r in good])
    if stats:
        print('p99 command -> halt write %.1f ms (target <= %.0f ms): %s' % (
            stats[2], TARGET_P99_MS, 'met' if stats[2] <= TARGET_P99_MS else 'NOT met'))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', default=os.environ.get('HARVEST_SCENARIO', 'default'))
    parser.add_argument('--trials', type=int, default=100)
    parser.add_argument('--load', action='store_true', help='two stress-ng --cpu 1 hogs beside it')
    parser.add_argument('--time-scale', type=float, default=float(DEFAULT_TIME_SCALE))
    parser.add_argument('--min-gap', type=float, default=0.5, help='wall s between stops, at least')
    parser.add_argument('--max-gap', type=float, default=3.0, help='wall s between stops, at most')
    parser.add_argument('--while-moving', action='store_true',
                        help='after each gap, wait until an axis moves and stop then')
    parser.add_argument('--seed', type=int, default=None)
    parser.add_argument('--log', default='bench_estop.log', help='roslaunch output file')
    parser.add_argument('--json', help='also write every trial to this file')
    parser.add_argument('--worker', action='store_true', help=argparse.SUPPRESS)
    parser.add_argument('--first', type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument('--out', help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        return worker(args)
    hogs = start_hogs() if args.load else []
    results, launches, empty = [], 0, 0
    print('[estop] %d stops, scenario %s, time scale %g%s; load average %s' % (
        args.trials, args.scenario, args.time_scale, ', two CPU hogs' if hogs else '',
        ' '.join('%.2f' % x for x in os.getloadavg())))
    sys.stdout.flush()
    try:
        while len(results) < args.trials and empty < 2:
            with tempfile.NamedTemporaryFile(suffix='.json', delete=False) as tmp:
                out = tmp.name
            seed = None if args.seed is None else args.seed + launches
            cmd = [sys.executable, os.path.abspath(__file__), '--worker', '--out', out,
                   '--trials', str(args.trials - len(results)), '--scenario', args.scenario,
                   '--time-scale', str(args.time_scale), '--min-gap', str(args.min_gap),
                   '--max-gap', str(args.max_gap), '--log', args.log,
                   '--first', str(len(results))] + (['--while-moving'] if args.while_moving else []) + ([] if seed is None else ['--seed', str(seed)])
            subprocess.call(cmd)
            launches += 1
            with open(out) as stream:
                got = json.load(stream)
            os.unlink(out)
            results += got['results']
            empty = empty + 1 if not got['results'] else 0
            print('[estop] launch %d: %d stops (%d in all)%s; load average %s' % (
                launches, len(got['results']), len(results),
                '' if got['status'] == 'ok' else '; ' + got['status'],
                ' '.join('%.2f' % x for x in os.getloadavg())))
            sys.stdout.flush()
    finally:
        stop_hogs(hogs)
    if args.json:
        with open(args.json, 'w') as stream:
            json.dump(results, stream, indent=1)
    report(results, bool(hogs))
    good = [r for r in results if 'error' not in r]
    return 0 if good and len(good) == len(results) else 1


if __name__ == '__main__':
    sys.exit(main())
