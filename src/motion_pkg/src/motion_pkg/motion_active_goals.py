"""The running goals of ``motion_server``: ``_Active`` (one goal, its monitor and how to finish
it), the answer to a goal that failed on an internal error, and the bookkeeping of the running
goals (``ActiveGoalsMixin``: register, release, take, abort, preempt), mixed into
``motion_server.MotionServer``."""

import functools

import rospy

from motion_pkg import motion_goals as mg
from motion_pkg.modbus_driver import DriverError


def _internal_error(action, exc):
    """Outcome of a goal that failed on an unexpected error (logged with its traceback)."""
    rospy.logerr('%s goal failed on an internal error: %r', action, exc, exc_info=True)
    return mg.Outcome(False, mg.FAILURE, 'internal error: %s' % exc)


def answer(handle, name, result, outcome, preempted=False):
    """End a goal with `result` and the outcome's text: succeeded, canceled when it was
    preempted, else aborted (logged)."""
    if outcome.success:
        handle.set_succeeded(result, outcome.text)
    elif preempted:
        handle.set_canceled(result, outcome.text)
    else:
        rospy.logwarn('%s aborted: %s', name, outcome.text)
        handle.set_aborted(result, outcome.text)


class _Active(object):
    """One running goal: its server, goal handle, monitor and how to finish it."""

    def __init__(self, key, handle, monitor, finish, feedback, resend=None):
        self.key = key
        self.handle = handle
        self.monitor = monitor
        self.finish = finish        # callable(handle, outcome, state)
        self.feedback = feedback    # callable(handle, monitor, state) or None
        self.resend = resend        # callable(): writes the goal's commands again after a link
        #                             outage (absolute targets, a valve state); None: aborted then


class ActiveGoalsMixin(object):
    """Goal bookkeeping of MotionServer (its _lock, _active, _arm_goals, _state, _poll_index)."""

    # --- goal bookkeeping ----------------------------------------------------------------
    def _start_or_answer(self, name, handle, start, finish):
        """The goal's _Active from start(); a goal it refuses (GoalError, DriverError:
        INVALID_GOAL) or that fails on an internal error is answered by finish, and None
        returned: a goal is always answered."""
        try:
            return start()
        except (mg.GoalError, DriverError) as exc:
            finish(handle, mg.Outcome(False, mg.INVALID_GOAL, str(exc)), self._state)
        except Exception as exc:  # noqa: BLE001 - a goal is always answered
            finish(handle, _internal_error(name, exc), self._state)
        return None

    def _register(self, entry):
        """Make the goal active and poll at once: quick goals end without waiting a period."""
        with self._lock:
            self._active[entry.key] = entry
        self._poll_once(own=entry.key)

    def _release(self, entry):
        """Remove the entry if it is still an active one; True when removed."""
        with self._lock:
            if entry.key == 'move_robot':
                return self._arm_goals.remove(entry)
            if self._active.get(entry.key) is entry:
                del self._active[entry.key]
                return True
            return False

    def _take(self, key):
        with self._lock:
            return self._active.pop(key, None)

    def _abort_actions(self, code, text, keys=None):
        """Deactivate goals (all, or those of the given servers); returns their abort calls
        as (server name, call) pairs."""
        with self._lock:
            keys = list(self._active) + ['move_robot'] if keys is None else keys
            entries = [self._active.pop(k) for k in keys if k in self._active]
            if 'move_robot' in keys:
                entries.extend(self._arm_goals.clear())      # every arm's goal
            state = self._state
        return [(e.key, functools.partial(e.finish, e.handle, mg.Outcome(False, code, text),
                                          state)) for e in entries]

    def _snapshot(self):
        with self._lock:
            return self._poll_index, self._state

    def _on_preempt(self, key, server):
        if server.is_new_goal_available():
            return                              # the goal callback replaces the goal
        entry = self._take(key)
        if entry is None:
            return
        text = self._halt_entry(entry) if key == 'move_base' else 'preempted'
        entry.finish(entry.handle, mg.Outcome(False, mg.HALTED, text), self._state,
                     preempted=True)
