#!/usr/bin/env python3
"""Screenshots of rviz and the dashboard during a simulated mission, for the documentation.

Starts a private ROS master with `harvest_bringup sim.launch`, rviz (launch/rviz.launch) on one
Xvfb display and the dashboard (launch/dashboard.launch) on another, waits until the mission has
finished a few fruit and an arm is moving, then grabs both screens with ImageMagick `import`.

Usage (workspace built and sourced; Debian packages xvfb and imagemagick):
  python3 src/visualization_pkg/tools/doc_screenshots.py [--out docs] [--fruit 2] [--time-scale 2]
  (--console --prefix console_: rviz embedded in the dashboard and the shell dock, as on the robot)
"""
import argparse
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from rospy.rostime import wallsleep  # wall time on purpose: the harness measures sim vs wall time

from harvest_sim.instance import free_port, sim_launch_args
from harvest_test_utils.xvfb import start_xvfb


class Harness(object):
    def __init__(self, args):
        self.args = args
        self.procs = []
        self.port = free_port()
        self.master = 'http://127.0.0.1:%d' % self.port
        self.env = dict(os.environ, ROS_MASTER_URI=self.master, ROS_HOSTNAME='localhost')
        os.environ.update({'ROS_MASTER_URI': self.master, 'ROS_HOSTNAME': 'localhost'})
        self.logdir = tempfile.mkdtemp(prefix='doc_screenshots_')

    def start(self, name, cmd, display=None):
        env = dict(self.env)
        if display is not None:
            env['DISPLAY'] = ':%d' % display
        with open(os.path.join(self.logdir, name + '.log'), 'w') as log:     # the child keeps its copy
            proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env, start_new_session=True)
        self.procs.append((name, proc))
        return proc

    def xvfb(self, size):
        """A display number, the display accepting clients (Xvfb picks a free one)."""
        with open(os.path.join(self.logdir, 'xvfb%d.log' % len(self.procs)), 'w') as log:
            proc, display = start_xvfb('%sx24' % size, stdout=log, stderr=subprocess.STDOUT,
                                       start_new_session=True)
        self.procs.append(('xvfb' + display[1:], proc))
        return int(display[1:])

    def grab(self, display, title, path):
        """Grab the top-level window whose name contains `title` (else the whole screen)."""
        tree = subprocess.run(['xwininfo', '-display', ':%d' % display, '-root', '-children'], stdout=subprocess.PIPE,
                              timeout=30).stdout.decode('utf-8', 'replace')
        window = 'root'
        for line in tree.splitlines():
            parts = line.split()
            if parts and parts[0].startswith('0x') and title in line:
                window = parts[0]
                break
        subprocess.run(['import', '-display', ':%d' % display, '-window', window, path], check=True, timeout=60)
        print('[screenshots] wrote %s (window %s)' % (path, window))

    def stop(self):
        for name, proc in reversed(self.procs):
            if proc.poll() is None:
                try:
                    os.killpg(proc.pid, signal.SIGINT)
                    proc.wait(timeout=20)
                except (subprocess.TimeoutExpired, ProcessLookupError):
                    try:
                        os.killpg(proc.pid, signal.SIGKILL)
                    except ProcessLookupError:
                        pass


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--out', default='docs', help='directory for rviz.png and dashboard.png')
    parser.add_argument('--scenario', default='default')
    parser.add_argument('--time-scale', type=float, default=2.0)
    parser.add_argument('--fruit', type=int, default=2, help='finished fruit before the screenshots')
    parser.add_argument('--timeout', type=float, default=900.0, help='wall seconds')
    parser.add_argument('--schedule', default='', help="the task planner's schedule (paper, "
                        "pipelined; '' = executive.yaml's)")
    parser.add_argument('--prefix', default='', help='file name prefix, e.g. pipelined_ -> '
                        'pipelined_rviz.png, pipelined_dashboard.png')
    parser.add_argument('--console', action='store_true',
                        help='the dashboard with rviz embedded as a dock and the shell enabled '
                        '(the whole operator console of the paper\'s Figure 10)')
    args = parser.parse_args()
    h = Harness(args)
    print('[screenshots] logs in %s' % h.logdir)
    try:
        h.start('sim', ['roslaunch', '-p', str(h.port), 'harvest_bringup', 'sim.launch', 'scenario:=' + args.scenario,
                        'time_scale:=%g' % args.time_scale, 'db_path:=' + os.path.join(h.logdir, 'sim.db'),
                        'mission_id:=screenshot-demo'] + sim_launch_args() +
                (['schedule:=' + args.schedule] if args.schedule else []))
        import rosgraph
        deadline = time.time() + 90
        while not rosgraph.is_master_online(h.master):
            if time.time() > deadline:
                raise RuntimeError('no master')
            wallsleep(0.5)     # harness outside ROS
        rviz_display = h.xvfb('1600x1000')     # harvest.rviz asks for a 1500x900 window
        dash_display = h.xvfb('1920x1080')
        h.start('rviz', ['roslaunch', 'visualization_pkg', 'rviz.launch'], rviz_display)
        h.start('dashboard', ['roslaunch', 'visualization_pkg', 'dashboard.launch', 'restore:=false',
                              'geometry:=1800x1050',
                              'settings_file:=' + os.path.join(h.logdir, 'dashboard.ini')] +
                (['embedded_rviz:=true', 'enable_shell:=true'] if args.console else []),
                dash_display)
        import rospy
        from std_msgs.msg import String
        from harvest_msgs.msg import MoveRobotActionGoal, PickRecord
        from visualization_pkg import names
        rospy.init_node('doc_screenshots', anonymous=True, disable_signals=True)
        records, moving = [], threading.Event()
        rospy.Subscriber('/' + names.PICK_RECORDS, PickRecord, records.append)
        rospy.Subscriber('/' + names.MOVE_ROBOT + '/goal', MoveRobotActionGoal, lambda _m: moving.set())
        ended = []
        rospy.Subscriber('/' + names.SUMMARY, String, lambda m: ended.append(m.data))
        deadline = time.time() + args.timeout
        while len([r for r in records if r.outcome == PickRecord.OUTCOME_PICKED]) < args.fruit:
            if time.time() > deadline:
                raise RuntimeError('only %d fruit within the timeout' % len(records))
            if ended:
                raise RuntimeError('the mission ended after %d fruit: %s' % (len(records), ended[-1]))
            wallsleep(1.0)     # harness outside ROS
        moving.clear()
        moving.wait(120)
        wallsleep(1.5)         # let both windows draw the new goal
        os.makedirs(args.out, exist_ok=True)
        h.grab(rviz_display, 'harvest.rviz', os.path.join(args.out, args.prefix + 'rviz.png'))
        h.grab(dash_display, 'Harvest robot dashboard',
               os.path.join(args.out, args.prefix + 'dashboard.png'))
        return 0
    except RuntimeError as exc:
        print('[screenshots] %s (logs in %s)' % (exc, h.logdir))
        return 1
    finally:
        h.stop()


if __name__ == '__main__':
    sys.exit(main())
