"""`make demo`: the simulated continuous harvest from one command, headless.

Starts a private ROS master and `harvest_bringup sim.launch` (simulated plant factory + the whole
robot stack), waits for the executive's mission summary, reads the simulator's ground truth
(allowed here: this is a benchmark harness, not part of the robot stack) and prints

  speed: S s simulated in W s wall = X x real time
  mission: picked P of R ripe reachable, damaged D, skipped S, mean cycle C s/fruit (sim), wall W s

(the speed counts from the simulated clock's first tick to the mission summary; the closing
line's wall time counts from the launch). Exit status 0 only when the mission ended `succeeded`.

Each run has a private master, a free loopback port for the simulated Modbus controller and a
controller serial number of its own (harvest_sim.instance), so it can run beside another
simulation on the same machine: the robot stack drives only its own simulated controller.
"""
import argparse
import json
import os
import signal
import subprocess
import sys
import threading
import time

from control_pkg.mission import SCHEDULES
from harvest_sim.instance import free_port, sim_launch_args
from harvest_sim.truth import ground_truth_counts, wait_fruits_at_rest

DEFAULT_TIMEOUT = 900.0   # wall seconds
#: sim.launch's time scale (most simulated seconds per wall second; the clock runs at real time
#: while nothing moves in the simulated world, see harvest_bringup/README.md)
DEFAULT_TIME_SCALE = '20'


#: the executive's action servers and their action types (control_pkg config/executive.yaml)
WIRE_ACTIONS = (('self_test', 'Start'), ('move_base', 'MoveBase'), ('tomato_scan', 'TomatoScan'),
                ('spatial_temporal', 'SpatialTemporal'), ('kinematics', 'Kinematics'),
                ('move_robot', 'MoveRobot'), ('end_effector', 'EndEffector'),
                ('visual_servo', 'VisualServo'))


def fatal_lines(log_path, limit=3):
    """The [FATAL] lines of a launch log (a node that could not start, e.g. its port taken)."""
    try:
        with open(log_path, errors='replace') as stream:
            lines = [line.strip() for line in stream if '[FATAL]' in line]
    except OSError:
        return []
    return lines[:limit]


def run_mission(scenario, time_scale, timeout, log_path, launch_args=()):
    """Run one simulated mission; return a dict with the executive summary, ground truth, wall time
    and the speed reached (simulated / wall seconds from the clock's first tick to the summary).

    launch_args come after this run's own controller_port and controller_serial (so they may
    override them). Raises RuntimeError with the reason when the mission could not run to its end.
    """
    port = free_port()
    master = 'http://127.0.0.1:%d' % port
    env = dict(os.environ, ROS_MASTER_URI=master, ROS_HOSTNAME='localhost')
    os.environ.update({'ROS_MASTER_URI': master, 'ROS_HOSTNAME': 'localhost'})
    db_path = os.path.abspath('demo_harvest.db')
    own = sim_launch_args() + list(launch_args)
    print('[demo] this run: master port %d, %s' % (port, ' '.join(own)))
    sys.stdout.flush()
    wall_start = time.time()
    log = open(log_path, 'w')
    launch = subprocess.Popen(
        ['roslaunch', '-p', str(port), 'harvest_bringup', 'sim.launch', 'scenario:=%s' % scenario,
         'time_scale:=%g' % time_scale, 'db_path:=%s' % db_path, 'mission_id:=demo-%s' % scenario]
        + own,
        stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    import rosgraph
    import rospy
    from std_msgs.msg import String
    done = threading.Event()
    state = {}

    def on_summary(msg):
        state['summary'] = json.loads(msg.data)
        done.set()

    records = []
    moves = []

    def on_move(msg):
        """Every arm move sent (the executive's and the visual servo's), for the benchmark's
        motion-time lower bound (tools/bench_mission.py)."""
        goal = msg.goal
        moves.append({'t': msg.header.stamp.to_sec() or msg.goal_id.stamp.to_sec(),
                      'arm': 'left' if goal.arm else 'right',
                      'positions': list(goal.target_joint.positions),
                      'waist': float(goal.waist) if getattr(goal, 'move_waist', False) else None})

    wire = []
    executive = '/task_planner'

    def on_wire(kind, action):
        """Goals the executive sends and the results it gets back, with their wall arrival time
        here (tools/bench_mission.py: the executive's overhead between one state's result and
        the next state's goal). Goals of other clients (the visual servo's) are left out."""
        def cb(msg):
            gid = msg.goal_id.id if kind == 'goal' else msg.status.goal_id.id
            if gid.startswith(executive + '-'):
                wire.append((time.monotonic(), kind, action, gid))
        return cb

    def on_record(msg):
        names = {msg.OUTCOME_PICKED: 'picked', msg.OUTCOME_UNREACHABLE: 'unreachable',
                 msg.OUTCOME_LOST: 'lost', msg.OUTCOME_FAILED: 'failed'}
        records.append({'picking_point': msg.picking_point, 'target_id': msg.target_id,
                        'outcome': names.get(msg.outcome, 'failed'),
                        'end': msg.stamp.to_sec(),
                        'cycle_time': msg.cycle_time, 'states': list(msg.state_names),
                        'durations': list(msg.state_durations)})

    try:
        deadline = time.time() + 60.0
        while not rosgraph.is_master_online(master):
            if time.time() > deadline or launch.poll() is not None:
                raise RuntimeError('roslaunch did not start a master; see %s' % log_path)
            time.sleep(0.2)   # harness polling the master from outside ROS; not node code
        # this node must follow /clock like the others: /use_sim_time is set by the launch
        while not rosgraph.Master('/harvest_demo').hasParam('/use_sim_time'):
            if time.time() > deadline or launch.poll() is not None:
                raise RuntimeError('the launch set no /use_sim_time; see %s' % log_path)
            time.sleep(0.05)  # harness polling the master from outside ROS; not node code
        if not rospy.core.is_initialized():
            rospy.init_node('harvest_demo', anonymous=True, disable_signals=True)
        sub = rospy.Subscriber('/mission/summary', String, on_summary)
        from harvest_msgs.msg import PickRecord
        rec_sub = rospy.Subscriber('/mission/pick_records', PickRecord, on_record, queue_size=100)
        from harvest_msgs.msg import MoveRobotActionGoal
        move_sub = rospy.Subscriber('/move_robot/goal', MoveRobotActionGoal, on_move,
                                    queue_size=100)
        import harvest_msgs.msg as hm
        wire_subs = []
        for action, spec in WIRE_ACTIONS:
            for kind, suffix in (('goal', 'Goal'), ('result', 'Result')):
                wire_subs.append(rospy.Subscriber(
                    '/%s/%s' % (action, kind), getattr(hm, '%sAction%s' % (spec, suffix)),
                    on_wire(kind, action), queue_size=100, tcp_nodelay=True))
        first = None              # (wall, sim) of the first tick of the simulated clock seen
        while not done.wait(0.05 if first is None else 0.5):
            if first is None and rospy.get_time() > 0.0:
                first = (time.time(), rospy.get_time())
            if launch.poll() is not None:
                raise RuntimeError('the launch ended before the mission did%s; see %s' % (
                    ''.join(': ' + line for line in fatal_lines(log_path)), log_path))
            if time.time() - wall_start > timeout:
                raise RuntimeError('no mission summary within %.0f s; see %s' % (timeout, log_path))
        end = (time.time(), rospy.get_time())
        sub.unregister()
        rec_sub.unregister()
        move_sub.unregister()
        for s in wire_subs:
            s.unregister()
        wall = end[0] - wall_start
        if first is None:
            first = end
        sim_span, wall_span = end[1] - first[1], end[0] - first[0]
        fruits = wait_fruits_at_rest(launch) or []
        from harvest_sim.srv import GetSimSummary
        rospy.wait_for_service('/sim/get_summary', timeout=10.0)
        truth = rospy.ServiceProxy('/sim/get_summary', GetSimSummary)()
        return {'summary': state['summary'], 'truth': truth, 'wall': wall, 'sim_span': sim_span,
                'wall_span': wall_span, 'records': list(records), 'moves': list(moves),
                'wire': list(wire),
                'fruit_states': dict((f.id, int(f.state)) for f in fruits)}
    finally:
        stop_launch(launch)
        log.close()


def write_run(path, run, scenario, schedule):
    """The run as JSON for tools/bench_mission.py."""
    truth = run['truth']
    ripe_reachable, harvested, damaged = ground_truth_counts(truth)
    data = {'scenario': scenario, 'schedule': schedule or '', 'summary': run['summary'],
            'truth': {'ripe_reachable': ripe_reachable, 'harvested': harvested, 'damaged': damaged},
            'wall': run['wall'], 'records': run['records'], 'moves': run['moves'],
            'fruit_states': run['fruit_states'], 'wire': run.get('wire', [])}
    with open(path, 'w') as stream:
        json.dump(data, stream, indent=1)


def stop_launch(launch, grace=30.0):
    """SIGINT to the launch's process group, SIGKILL after `grace` s. A launch that has already
    ended (e.g. a required node died: its process group is gone) is left as it is."""
    try:
        os.killpg(launch.pid, signal.SIGINT)
        launch.wait(timeout=grace)
    except ProcessLookupError:
        pass
    except subprocess.TimeoutExpired:
        try:
            os.killpg(launch.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        launch.wait()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--scenario', default=os.environ.get('HARVEST_SCENARIO', 'default'))
    parser.add_argument('--time-scale', type=float,
                        default=float(os.environ.get('HARVEST_TIME_SCALE', DEFAULT_TIME_SCALE)))
    parser.add_argument('--timeout', type=float, default=DEFAULT_TIMEOUT, help='wall seconds')
    parser.add_argument('--log', default='demo.log', help='roslaunch output file')
    parser.add_argument('--json', default='',
                        help='also write the run (summary, ground truth, pick records, the state of '
                             'every simulated fruit) to this file (tools/bench_mission.py)')
    parser.add_argument('--schedule', choices=SCHEDULES,
                        default=os.environ.get('HARVEST_SCHEDULE') or None,
                        help="the task planner's schedule (default: control_pkg executive.yaml's)")
    parser.add_argument('--depth-probe', type=float, default=None, metavar='M',
                        help='the visual servo first ranges the fruit with the hand camera from two poses M '
                             'metres apart sideways (sim.launch depth_probe; default: its 0, off)')
    parser.add_argument('--servo-mode', choices=('step', 'continuous'), default=None,
                        help="the visual servo's mode (default: step, the paper's)")
    args = parser.parse_args()
    extra = ['schedule:=%s' % args.schedule] if args.schedule else []
    if args.servo_mode:
        extra.append('servo_mode:=%s' % args.servo_mode)
    if args.depth_probe is not None:
        extra.append('depth_probe:=%g' % args.depth_probe)
    print('[demo] roslaunch harvest_bringup sim.launch scenario:=%s time_scale:=%g%s (log: %s)'
          % (args.scenario, args.time_scale, ''.join(' ' + e for e in extra), args.log))
    sys.stdout.flush()
    try:
        run = run_mission(args.scenario, args.time_scale, args.timeout, args.log, extra)
    except RuntimeError as exc:
        print('[demo] %s' % exc)
        return 1
    summary, truth = run['summary'], run['truth']
    ripe_reachable, harvested, damaged = ground_truth_counts(truth)
    skipped = summary['unreachable'] + summary['lost'] + summary['failed']
    print('[demo] mission %s ended %s after %d picking points; executive record: picked %d, '
          'unreachable %d, lost %d, failed %d%s' % (
              summary['mission_id'], summary['outcome'], summary['points_visited'], summary['picked'],
              summary['unreachable'], summary['lost'], summary['failed'],
              ('; last error: %s' % summary['last_error']) if summary.get('last_error') else ''))
    print('[demo] ground truth (%s): %d fruit, %d ripe, %d ripe reachable; collected %d (ripe %d, unripe %d), '
          'dropped %d, damaged %d' % (truth.scenario, truth.total, truth.ripe, truth.ripe_reachable,
                                      truth.collected, truth.collected_ripe, truth.collected_unripe,
                                      truth.dropped, truth.damaged))
    print('speed: %.0f s simulated in %.1f s wall = %.1fx real time' % (
        run['sim_span'], run['wall_span'], run['sim_span'] / max(run['wall_span'], 1e-6)))
    if args.json:
        write_run(args.json, run, args.scenario, args.schedule)
    from control_pkg.mission import summary_line
    print(summary_line(harvested, ripe_reachable, damaged, skipped, summary['mean_cycle_time'], run['wall']))
    return 0 if summary['outcome'] == 'succeeded' else 1


if __name__ == '__main__':
    sys.exit(main())
