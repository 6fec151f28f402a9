"""Status of ``motion_server`` (``StatusMixin``, mixed into ``motion_server.MotionServer``):
the latched ``motion_status`` (published on change) and the ``/diagnostics`` of the Modbus
connection, the poll rate and every axis."""

import diagnostic_updater
import rospy
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from motion_pkg import motion_goals as mg

POLL_RATE_TOLERANCE = 0.2          # diagnostics: poll rate within +-20 % of ~poll_rate is OK
POLL_RATE_WINDOW = 10              # diagnostics: averaging window (updates)
LEVEL_NAMES = {0: 'OK', 1: 'WARN', 2: 'ERROR'}


class StatusMixin(object):
    """motion_status and diagnostics of MotionServer (its driver, regmap, endpoint, _state)."""

    # --- status and diagnostics ----------------------------------------------------------
    def _setup_diagnostics(self):
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID('modbus %s unit %d' % (self.endpoint, self.driver.unit))
        self.updater.add('Modbus connection', self._diag_connection)
        self.poll_freq = diagnostic_updater.FrequencyStatus(
            diagnostic_updater.FrequencyStatusParam(
                {'min': self.poll_rate, 'max': self.poll_rate}, POLL_RATE_TOLERANCE,
                POLL_RATE_WINDOW))
        self.updater.add(self.poll_freq)
        for info in self.regmap.axes:
            self.updater.add('Axis %s' % info.name,
                             lambda stat, index=info.index: self._diag_axis(stat, index))

    def _summary(self):
        return mg.status_summary(self.driver.connected, self.driver.last_error, self._state,
                                 self.regmap, self.endpoint, self._poll_error)

    def _publish_status(self):
        with self._status_lock:
            level, message = self._summary()
            if (level, message) == self._last_status:
                return
            self._last_status = (level, message)
            values = [KeyValue('endpoint', self.endpoint),
                      KeyValue('controller_serial', str(self.driver.serial_number)),
                      KeyValue('connected', str(self.driver.connected)),
                      KeyValue('connections', str(self.driver.connects))]
            self.status_pub.publish(DiagnosticStatus(
                level=level, name=rospy.get_name(), message=message,
                hardware_id='modbus %s' % self.endpoint, values=values))
        if level == 0:
            rospy.loginfo('motion status OK: %s', message)
        else:
            rospy.logwarn('motion status %s: %s', LEVEL_NAMES[level], message)

    def _diag_connection(self, stat):
        level, message = self._summary()
        stat.summary(2 if not self.driver.connected or self._poll_error else 0,
                     'connected' if self.driver.connected and not self._poll_error else message)
        stat.add('endpoint', self.endpoint)
        stat.add('unit id', self.driver.unit)
        stat.add('controller serial number', self.driver.serial_number)
        stat.add('connections made', self.driver.connects)
        stat.add('connections lost', self.driver.failures)
        stat.add('last error', self.driver.last_error or self._poll_error or '-')
        stat.add('system status', '%s: %s' % (LEVEL_NAMES[level], message))
        return stat

    def _diag_axis(self, stat, index):
        state = self._state
        if state is None or not self.driver.connected:
            stat.summary(2, 'no data (not connected)')
            return stat
        axis = state.axes[index]
        if axis.fault:
            stat.summary(2, 'fault %d: %s' % (axis.fault_code,
                                              self.regmap.fault_text(axis.fault_code)))
        elif not axis.enabled:
            stat.summary(1, 'disabled')
        else:
            stat.summary(0, 'moving' if axis.moving else 'enabled, at rest')
        stat.add('position', '%.5f' % axis.position)
        stat.add('velocity', '%.5f' % axis.velocity)
        stat.add('status word', '0x%04x' % axis.status)
        stat.add('fault code', axis.fault_code)
        stat.add('in position', axis.in_position)
        return stat
