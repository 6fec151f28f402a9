"""An actionlib SimpleActionClient for the rostest clients that cannot lose a fast result.

actionlib's SimpleActionClient (1.14, Debian's) publishes the goal first and stores the goal
handle after: a server that answers before the store has its ACTIVE and DONE transitions
dropped ("Got a transition callback on a goal handle that we're not tracking", ros/actionlib
#206), and wait_for_result() then waits for its whole timeout. On a loaded machine a kinematics
goal was lost that way (`kinematics_test`, "no result" after 10 s, beside the mission tests).

TrackedActionClient keeps SimpleActionClient's interface. It holds a lock while it sends, so a
transition from the subscriber thread waits until the handle is stored; a transition that the
sending thread itself receives before the store is kept and replayed after it. The robot's own
nodes avoid SimpleActionClient for the same reason (control_pkg's action states, the
dashboard, database_pkg).
"""
import threading

import actionlib


class TrackedActionClient(actionlib.SimpleActionClient):
    """SimpleActionClient whose goal handle is stored before any transition of it is handled."""

    def __init__(self, ns, action_spec):
        self._init_tracking()
        super(TrackedActionClient, self).__init__(ns, action_spec)

    def _init_tracking(self):
        self._send_lock = threading.RLock()
        self._sending = False
        self._early = []

    def send_goal(self, goal, done_cb=None, active_cb=None, feedback_cb=None):
        with self._send_lock:
            self._sending = True
            self._early = []
            try:
                super(TrackedActionClient, self).send_goal(goal, done_cb, active_cb, feedback_cb)
            finally:
                self._sending = False
            replay = any(gh == self.gh for gh in self._early)
            self._early = []
            if replay:
                # the handle's comm state is current: one call brings the simple state there
                super(TrackedActionClient, self)._handle_transition(self.gh)

    def _handle_transition(self, gh):
        with self._send_lock:
            if self._sending:
                self._early.append(gh)
                return
            super(TrackedActionClient, self)._handle_transition(gh)

    def _handle_feedback(self, gh, feedback):
        with self._send_lock:
            super(TrackedActionClient, self)._handle_feedback(gh, feedback)
