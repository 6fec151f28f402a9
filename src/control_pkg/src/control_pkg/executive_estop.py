"""The task planner's emergency stop and resume (executive_node.TaskPlanner's base class).

The emergency_stop topic and the services ~emergency_stop, ~resume and ~start: a stop halts the
axes at once and ends RUN (ESTOP_MONITOR, then DO_STOP); a resume ends the pause, or continues a
mission that DO_ERROR ended once the operator has cleared the fault (continue_after_fault).
Uses what TaskPlanner.__init__ sets (the `estop` and `resume` events, `sm`, `context`,
`recorder`, `progress`, `checkpoints`, `config`, `mission_id`, `outcome`, the run lock and thread,
the fault snapshot, the halt_all proxy and its lock) and its `publish_event` and `start`.
"""
import rospy
from std_srvs.srv import Trigger, TriggerResponse

from control_pkg import checkpoint as checkpoint_lib
from control_pkg.executive_states import clear_preempts
from control_pkg import mission as mission_lib
from control_pkg import names


class EmergencyStopAndResume(object):
    """The emergency stop and resume of TaskPlanner: topic and service callbacks, halt_all."""

    def _estop_topic_cb(self, msg):
        """The topic is the stop button's level, latched by its publishers: a stop is its rise
        to true, a resume its fall to false. A true that finds the level true already is no
        new stop (stop_heard_by_motion)."""
        with self._estop_level_lock:
            rising = msg.data and not self._estop_level
            self._estop_level = bool(msg.data)
        if rising:
            self.request_stop('emergency_stop topic')
        elif not msg.data:
            self.request_resume('emergency_stop topic released')
        else:
            rospy.loginfo('task_planner: emergency_stop topic true, as already known: no new stop')

    def stop_heard_by_motion(self, source):
        """A goal came back halted by the emergency stop topic, which motion_server heard before
        this node did: the topic is true. Its message can reach this node after the operator's
        resume (a busy machine: it then stopped the resumed mission again, for good), so the
        level is noted true here and that message is no new stop."""
        with self._estop_level_lock:
            self._estop_level = True
        self.request_stop(source)

    def _estop_srv(self, req):
        self.request_stop('emergency_stop service')
        return TriggerResponse(success=True, message='emergency stop requested')

    def _resume_srv(self, req):
        if self.estop.is_set():
            self.request_resume('resume service')
            return TriggerResponse(success=True, message='resume requested')
        if self.outcome == 'aborted' and self._fault_snapshot is not None:
            ok, message = self.continue_after_fault()
            return TriggerResponse(success=ok, message=message)
        return TriggerResponse(success=False, message='not stopped')

    def continue_after_fault(self):
        """After DO_ERROR ended the mission (a drive fault, a component down) and the operator
        cleared the cause (motion_pkg's enable_all, a restarted component): the same mission
        goes on from its last checkpoint as after a restart of this node (RESUME: the robot's
        real state made safe, then DO_START's self-test, which refuses a fault still there,
        then the interrupted picking point scanned again). The fruit DO_ERROR recorded failed
        is tried again: that record does not skip it."""
        with self._run_lock:
            if self._thread is not None:
                self._thread.join(5.0)       # it ends right after the summary
            snap = self._fault_snapshot
            if snap is None or (self._thread is not None and self._thread.is_alive()):
                return False, 'nothing to continue: the mission did not end in DO_ERROR'
            recorded = [(f.picking_point, f.target_id, f.position) for f in self.recorder.fruits
                        if f.outcome != mission_lib.OUTCOME_FAILED]
            try:
                plan = checkpoint_lib.resume_plan(snap, recorded,
                                                  float(self.config['resume_skip_tolerance']))
                if snap.points:
                    self.progress.resume_at(snap.points, plan.point_index)
            except ValueError as exc:
                return False, 'cannot continue mission %s: %s' % (self.mission_id, exc)
            fault = self.context.last_error
            self._fault_snapshot = None
            self.checkpoints.restore(snap)
            self.context.skip[snap.picking_point] = plan.skip
            self.context.resume = plan
            self.context.resume_snapshot = snap
            self.context.last_error = ''
            self.outcome = None
            self.resuming = True
            clear_preempts(self.sm)
            self.publish_event('resume', 'DO_ERROR', 'mission %s continued after the fault (%s): %s'
                               % (self.mission_id, fault, plan.why))
            rospy.logwarn('task_planner: continuing mission %s after the fault (%s): %s',
                          self.mission_id, fault, plan.why)
            self.start()
        return True, 'mission %s continued: %s' % (self.mission_id, plan.why)

    def _start_srv(self, req):
        with self._run_lock:
            if self._thread is not None:
                return TriggerResponse(success=False, message='mission already started (outcome: %s)%s' % (
                    self.outcome, '; after DO_ERROR, ~resume continues it' if self.outcome == 'aborted' else ''))
            self.start()
        return TriggerResponse(success=True, message='mission %s started' % self.mission_id)

    def request_stop(self, source):
        if not self.estop.is_set():
            self.estop.set()
            self.sm.estop_monitor.wake()
            # halt at once, from the thread that took the command: DO_STOP halts again once the
            # state machine has unwound (tens to hundreds of ms later), and that second halt
            # also covers a goal a state sent while the stop was under way
            ok, message = self.halt_axes()
            rospy.logwarn('task_planner: emergency stop from %s; axes halted: %s (%s)', source, ok,
                          message)

    def request_resume(self, source):
        if self.estop.is_set():
            rospy.loginfo('task_planner: resume from %s', source)
            self.resume.set()

    def halt_axes(self):
        """Call halt_all through a persistent connection (made again once if it broke)."""
        with self._halt_lock:
            for attempt in (0, 1):
                try:
                    if self._halt is None:
                        rospy.wait_for_service(names.HALT_ALL, timeout=2.0)
                        self._halt = rospy.ServiceProxy(names.HALT_ALL, Trigger, persistent=True)
                    resp = self._halt()
                    return resp.success, resp.message
                except (rospy.ROSException, rospy.ServiceException) as exc:
                    if self._halt is not None:
                        self._halt.close()
                        self._halt = None
                    if attempt:
                        return False, 'halt_all unavailable: %s' % exc
