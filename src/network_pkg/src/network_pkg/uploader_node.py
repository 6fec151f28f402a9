"""ROS node ``uploader``: the robot's side of the data layer (section 3.3).

Drains the local store (database_pkg) into the farm server and offers the server's plan of the
day to the executive. The logic is network_pkg.outbox (no rospy); this class adapts timing,
parameters, the plan topic and diagnostics.

Publications:
  plan/picking_points (std_msgs/Int32MultiArray, latched): picking point indices of today's plan
      in visit order; published when a plan is received and whenever it changes; never when
      the server has no plan for this robot (the executive then keeps its track order). An
      empty array is a real plan: nothing is worth visiting today.
  /diagnostics (via diagnostic_updater): queue per table, rows sent, last error, last success.
Params (private, defaults in code and config/uploader.yaml):
  ~server_url, ~token or ~token_file, ~db_path, ~batch_size, ~timeout, ~backoff_initial,
  ~backoff_max, ~idle_period, ~min_interval, ~plan_period, ~plan_day, ~plan_row, ~ca_file,
  ~stale_after. Also sets ~plan (list of int) and ~plan_day (str) with the last plan received.

Timing: uploads and back-off run in a worker thread that waits on an Event in wall-clock
seconds (the network and the server live in wall time; simulated time may be paused or run
fast). The plan refresh and diagnostics use rospy.Timer (ROS time).
"""

import os
import threading
import time

import diagnostic_updater
import rospy
from diagnostic_msgs.msg import DiagnosticStatus
from std_msgs.msg import Int32MultiArray

from network_pkg import names
from network_pkg.outbox import TABLE_ORDER, Backoff, FarmClient, Outbox, UploadError, Uploader

__all__ = ['UploaderNode', 'UploaderNodeError']

DIAGNOSTICS_PERIOD_S = 1.0
DEFAULT_DB = os.path.join('~', '.ros', 'harvest', 'harvest.db')
UNAUTHORIZED = 401


class UploaderNodeError(RuntimeError):
    """A required parameter is missing or unusable."""


def _age(now, then):
    return 'never' if then is None else '%.1f s ago' % max(0.0, now - then)


class UploaderNode(object):
    def __init__(self):
        self.server_url = rospy.get_param('~server_url', 'http://127.0.0.1:8420')
        token = rospy.get_param('~token', '')
        token_file = rospy.get_param('~token_file', '')
        if not token and token_file:
            try:
                with open(os.path.expanduser(token_file)) as f:
                    token = f.read().strip()
            except OSError as e:
                raise UploaderNodeError('cannot read ~token_file %s: %s' % (token_file, e))
        if not token:
            raise UploaderNodeError('no robot token: set ~token or ~token_file (create one on '
                                    'the server with `farm_server token add ROBOT`)')
        db_path = os.path.expanduser(rospy.get_param('~db_path', DEFAULT_DB))
        parent = os.path.dirname(db_path)
        if parent and not os.path.isdir(parent):
            os.makedirs(parent)
        self.stale_after = float(rospy.get_param('~stale_after', 600.0))
        self.plan_day = str(rospy.get_param('~plan_day', ''))
        self.plan_row = str(rospy.get_param('~plan_row', ''))
        ca_file = rospy.get_param('~ca_file', '')
        try:
            self.outbox = Outbox(db_path)
        except Exception as e:  # StoreError, SchemaVersionError, OSError: name the file
            raise UploaderNodeError('cannot open the local store %s: %s' % (db_path, e))
        self.client = FarmClient(self.server_url, token,
                                 timeout=float(rospy.get_param('~timeout', 10.0)),
                                 verify=ca_file if ca_file else True)
        self.uploader = Uploader(
            self.outbox, self.client, batch_size=int(rospy.get_param('~batch_size', 200)),
            backoff=Backoff(float(rospy.get_param('~backoff_initial', 1.0)),
                            float(rospy.get_param('~backoff_max', 60.0))),
            idle_period=float(rospy.get_param('~idle_period', 2.0)),
            min_interval=float(rospy.get_param('~min_interval', 0.0)))
        self.db_path = db_path

        self._plan_lock = threading.Lock()
        self._plan = None               # last plan list published
        self._plan_state = 'not asked yet'
        self._plan_time = None
        self._plan_due = threading.Event()
        self._plan_due.set()            # ask at once
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._started = time.time()
        self.plan_pub = rospy.Publisher(names.PLAN, Int32MultiArray, queue_size=1, latch=True)

        self._updater = diagnostic_updater.Updater()
        self._updater.setHardwareID('farm:%s' % self.server_url)
        self._updater.add('Farm uploader', self._diagnose)
        self._worker = threading.Thread(target=self._work, name='uploader')
        self._worker.daemon = True
        self._worker.start()
        self._plan_timer = rospy.Timer(rospy.Duration(float(rospy.get_param('~plan_period',
                                                                            300.0))),
                                       self._on_plan_timer)
        self._diag_timer = rospy.Timer(rospy.Duration(DIAGNOSTICS_PERIOD_S),
                                       lambda _e: self._updater.update())
        rospy.loginfo('uploader: %s -> %s', db_path, self.server_url)

    # ------------------------------------------------------------ worker

    def _on_plan_timer(self, _event):
        self._plan_due.set()
        self._wake.set()

    def _work(self):
        was_failing = False
        was_drained = False
        while not self._stop.is_set() and not rospy.is_shutdown():
            delay = self.uploader.step()
            status = self.uploader.status()
            failing = status['consecutive_failures'] > 0
            if failing and not was_failing:
                rospy.logwarn('uploader: %s; backing off', status['last_error'])
            elif was_failing and not failing:
                rospy.loginfo('uploader: server reachable again, upload resumed')
            elif failing:
                rospy.logwarn_throttle(60.0, 'uploader: still failing: %s' % status['last_error'])
            was_failing = failing
            if status['drained'] and not was_drained and status['sent'] > 0:
                self._plan_due.set()    # our own records are all on the server: re-plan now
            was_drained = status['drained']
            if self._plan_due.is_set():
                self._plan_due.clear()
                self._fetch_plan()
            if delay > 0:
                self._wake.wait(delay)
                self._wake.clear()

    def _fetch_plan(self):
        try:
            plan = self.client.plan(day=self.plan_day or None, row=self.plan_row or None)
        except UploadError as e:
            with self._plan_lock:
                self._plan_state = 'request failed: %s' % e
            rospy.logwarn_throttle(60.0, 'uploader: plan: %s' % e)
            return
        if plan is None:
            with self._plan_lock:
                self._plan_state = 'no plan from the server (no records of this robot yet)'
            return
        points = [int(p) for p in plan.get('picking_points', [])]
        with self._plan_lock:
            changed = points != self._plan
            self._plan = points
            self._plan_state = 'plan of %s, row %s: %d points' % (plan.get('day'),
                                                                  plan.get('row'), len(points))
            self._plan_time = time.time()
        if changed:
            rospy.set_param('~plan', points)
            rospy.set_param('~plan_day', str(plan.get('day', '')))
            self.plan_pub.publish(Int32MultiArray(data=points))
            rospy.loginfo('uploader: plan for %s (row %s): picking points %s',
                          plan.get('day'), plan.get('row'), points)

    # ------------------------------------------------------------ diagnostics

    def _diagnose(self, stat):
        now = time.time()
        status = self.uploader.status()
        try:
            queued = self.outbox.pending_counts()
            queue_error = ''
        except Exception as e:  # sqlite3.Error: shown, never fatal for diagnostics
            queued = dict((t, -1) for t in TABLE_ORDER)
            queue_error = str(e)
        total = sum(v for v in queued.values() if v > 0)
        last_ok = status['last_success_time']
        level, message = DiagnosticStatus.OK, 'up to date' if total == 0 else \
            '%d rows queued' % total
        if status['consecutive_failures'] > 0:
            level, message = DiagnosticStatus.WARN, 'server unreachable, %d rows queued' % total
            if status['last_error_status'] == UNAUTHORIZED:
                level, message = DiagnosticStatus.ERROR, 'token refused by the server'
        if total > 0 and now - (last_ok or self._started) > self.stale_after:
            level = DiagnosticStatus.ERROR
            message = 'no successful upload for %.0f s, %d rows queued' % (
                now - (last_ok or self._started), total)
        if queue_error:
            level, message = DiagnosticStatus.ERROR, 'local store unreadable: %s' % queue_error
        stat.summary(level, message)
        stat.add('server', self.server_url)
        stat.add('database', self.db_path)
        stat.add('queued', total)
        for table in TABLE_ORDER:
            stat.add('queued %s' % table, queued[table])
        stat.add('sent (rows since start)', status['sent'])
        stat.add('batches', status['batches'])
        stat.add('already on server (rows)', status['duplicates'])
        stat.add('batch size', status['batch_size'])
        stat.add('failures', status['failures'])
        stat.add('consecutive failures', status['consecutive_failures'])
        stat.add('next attempt in [s]', '%.1f' % status['next_attempt_in'])
        stat.add('last success', _age(now, last_ok))
        stat.add('last error', status['last_error'] or 'none')
        stat.add('last error at', _age(now, status['last_error_time']))
        with self._plan_lock:
            stat.add('plan', self._plan_state)
            stat.add('plan points', 'none' if self._plan is None else str(self._plan))
        return stat

    # ------------------------------------------------------------ shutdown

    def shutdown(self):
        self._stop.set()
        self._wake.set()
        self._plan_timer.shutdown()
        self._diag_timer.shutdown()
        self._worker.join(timeout=self.client.timeout + 1.0)
        self.client.close()
        self.outbox.close()
