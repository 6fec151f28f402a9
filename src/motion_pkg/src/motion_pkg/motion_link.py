"""The Modbus link of ``motion_server`` (``LinkMixin``, mixed into
``motion_server.MotionServer``): the poll thread's loop and one poll (``joint_states``, the goal
monitors), (re)connecting, and a lost link's grace period (``~link_grace``): goals wait for the
link, their commands are written again when it is back, or they are aborted once it is over."""

import functools

import rospy
from sensor_msgs.msg import JointState

from motion_pkg import motion_goals as mg
from motion_pkg.modbus_driver import ConnectionLost, ControllerRefused, DriverError


class LinkMixin(object):
    """Poll, reconnect and link grace of MotionServer (its driver, locks and goal tables)."""

    # --- poll loop -----------------------------------------------------------------------
    def _poll_loop(self):
        rate = rospy.Rate(self.poll_rate)
        while not rospy.is_shutdown() and not self._stop.is_set():
            self._poll_once()
            self.updater.update()
            try:
                rate.sleep()
            except rospy.ROSInterruptException:
                break
            except rospy.ROSTimeMovedBackwardsException:
                rate = rospy.Rate(self.poll_rate)

    def _poll_once(self, own=None):
        """One poll. Goal handles are only touched after the poll lock is released: a goal
        callback holds actionlib's lock while it waits for the poll lock. `own`: the server
        whose goal callback polls (it holds that server's lock): only that server's goals are
        fed and finished here, the others' by the poll thread (`motion_goals.split_actions`)."""
        with self._poll_lock:
            actions = self._poll_locked()
        now, later = mg.split_actions(actions, own)
        with self._lock:
            if own is None:
                now, self._deferred = [call for _, call in self._deferred] + now, []
            else:
                self._deferred.extend(later)
        for action in now:
            action()
        self._publish_status()

    def _poll_locked(self):
        """Poll the controller; returns the goal feedback / finish calls to make."""
        now = rospy.get_time()
        resumed = []
        if not self.driver.connected:
            if not self.driver.ensure_connected(now):
                if self.driver.refused and self.driver.refused != self._refusal_logged:
                    rospy.logerr('%s (~controller_serial %d); retrying with back-off',
                                 self.driver.refused, self.driver.serial_number)
                self._refusal_logged = self.driver.refused
                return self._outage_expired(now)
            self._refusal_logged = ''
            resumed = self._on_connected(now)
        try:
            state = self.driver.poll()
        except ConnectionLost as exc:
            rospy.logerr('%s', exc)
            if self.link_grace > 0.0:
                self._note_link_lost(exc, now)
                return resumed + self._outage_expired(now)
            return resumed + self._abort_actions(mg.CONNECTION_LOST, str(exc))
        except ControllerRefused as exc:
            self._poll_error = str(exc)
            rospy.logwarn_throttle(2.0, '%s' % exc)
            if self._last_good is None or now - self._last_good > self.stale_timeout:
                with self._lock:
                    self._state = None
                return self._abort_actions(mg.REFUSED, 'no valid data from the motion '
                                           'controller for %.1f s: %s'
                                           % (self.stale_timeout, exc))
            return []
        self._last_good = now
        self._poll_error = ''
        self.poll_freq.tick()
        with self._lock:
            self._poll_index += 1
            index = self._poll_index
            self._state = state
            active = list(self._active.values()) + self._arm_goals.goals()
        if now != self._joint_stamp:
            # a goal's own poll can come in the same clock step as the poll thread's: a
            # second joint state of one stamp would make robot_state_publisher send that tf
            # again (TF_REPEATED_DATA in every tf listener). (A clock that jumps back, a
            # restarted simulation or a looping bag, is published at once.)
            self._joint_stamp = now
            msg = JointState(name=self.regmap.joint_names, position=state.positions,
                             velocity=state.velocities)
            msg.header.stamp = rospy.Time.from_sec(now)
            self.joint_pub.publish(msg)
        actions = resumed
        for entry in active:
            outcome = entry.monitor.update(index, state, now)
            if outcome is None:
                if entry.feedback is not None:
                    actions.append((entry.key, functools.partial(
                        entry.feedback, entry.handle, entry.monitor, state)))
            elif self._release(entry):
                actions.append((entry.key, functools.partial(entry.finish, entry.handle,
                                                             outcome, state)))
        return actions

    def _on_connected(self, now):
        """Connected (again): nothing may run that no goal watches. After a link outage the
        goals that waited for it go on (`_resume_goals`); returns the finish calls to make."""
        rospy.loginfo('connected to the motion controller at %s (connection %d)',
                      self.endpoint, self.driver.connects)
        if self._link_lost_at is not None:
            lost_at, self._link_lost_at = self._link_lost_at, None
            return self._resume_goals(now - lost_at)
        try:
            self.driver.halt_all()
            if self.auto_enable:
                self.driver.system('enable_all')
        except DriverError as exc:
            rospy.logwarn('start-up commands failed: %s', exc)
        return []

    def _resume_goals(self, outage):
        """The link is back after `outage` s: every axis no goal holds is halted, each waiting
        goal's commands are written again (absolute targets: where the axes have got to in the
        meantime does not matter) and its deadline moved on by the outage; a goal that cannot be
        written again (a shear stroke) is aborted. Faults are not cleared: a drive that
        faulted meanwhile fails its goal at the next poll."""
        with self._lock:
            entries = list(self._active.values()) + self._arm_goals.goals()
            next_poll = self._poll_index + 1
        held = set(i for e in entries if e.resend is not None
                   for i in getattr(e.monitor, 'indices', ()))
        aborted = [e for e in entries if e.resend is None]
        try:
            idle = [i for i in range(len(self.regmap.axis_names)) if i not in held]
            if idle:
                self.driver.halt(idle)
            for entry in entries:
                if entry.resend is not None:
                    entry.resend()
                    entry.monitor.first_poll = next_poll
                    entry.monitor.deadline += outage
        except DriverError as exc:
            rospy.logerr('link back after %.1f s, but the goals cannot be written again: %s',
                         outage, exc)
            return self._abort_actions(mg.CONNECTION_LOST, 'the link to the motion controller '
                                       'came back, but writing failed: %s' % exc)
        rospy.logwarn('link to the motion controller back after %.1f s: %d goal(s) go on%s',
                      outage, len(entries) - len(aborted),
                      ', %d aborted' % len(aborted) if aborted else '')
        text = 'the link to the motion controller was down for %.1f s (%s)' % (
            outage, self._link_error)
        return [(e.key, functools.partial(e.finish, e.handle,
                                          mg.Outcome(False, mg.CONNECTION_LOST, text), None))
                for e in aborted if self._release(e)]

    def _outage_expired(self, now):
        """While the link is down: the waiting goals are aborted once `link_grace` is over."""
        if self._link_lost_at is None or now - self._link_lost_at <= self.link_grace:
            return []
        with self._lock:
            waiting = bool(self._active) or bool(self._arm_goals.goals())
        if not waiting:
            return []
        return self._abort_actions(mg.CONNECTION_LOST, 'no link to the motion controller at %s '
                                   'for %.1f s (~link_grace): %s' % (
                                       self.endpoint, now - self._link_lost_at,
                                       self.driver.last_error or self._link_error))

    def _note_link_lost(self, exc, now=None):
        """The link broke (a poll or a goal's write found it): goals wait `link_grace`."""
        if self.link_grace > 0.0 and self._link_lost_at is None:
            self._link_lost_at = rospy.get_time() if now is None else now
            self._link_error = str(exc)
            rospy.logwarn('goals wait up to %.1f s for the link to the motion controller',
                          self.link_grace)

    def _write_through_outage(self, write):
        """A goal's write(); when the link breaks during it, the goal waits for the link
        (`_await_link`) and writes everything again (absolute targets, a valve state)."""
        try:
            write()
        except ConnectionLost as exc:
            self._note_link_lost(exc)
            if not self._await_link():
                raise
            with self._poll_lock:
                write()

    def _await_link(self):
        """A goal that comes while the link is down (lost less than `link_grace` ago) waits for
        it (ROS time) before it is checked: the outage a running goal rides through does not
        fail the next goal either. True when connected."""
        if not self.driver.connected and self._link_lost_at is None and self.driver.connects > 0:
            # lost a moment ago: the poll thread has not noted it yet
            self._note_link_lost(self.driver.last_error or 'connection lost')
        while not self.driver.connected and not rospy.is_shutdown():
            lost_at = self._link_lost_at
            if lost_at is None or rospy.get_time() - lost_at > self.link_grace:
                break
            try:
                rospy.sleep(0.02)
            except rospy.ROSInterruptException:
                break
        if not self.driver.connected:
            return False
        with self._poll_lock:
            pass       # the poll thread has done its reconnection (it halts idle axes) first
        return self.driver.connected
