"""What the executive is doing, as far as the dashboard can tell, and what that allows by hand.

Sources (control_pkg task_planner): the root container's introspection status (active state RUN =
mission running, DO_STOP = paused by the emergency stop, ['None'] = idle) and the latched
`task_planner/state` text ('DO_STOP: axes halted: ...', 'DO_STOP: mission resumed', ...).
The newer of the two decides between running and paused.
"""

UNKNOWN = 'unknown'     # just started, nothing heard yet (may still be a running mission)
OFFLINE = 'offline'     # no executive: no introspection for longer than the heartbeat allows
IDLE = 'idle'           # executive up, no mission running (not started or finished)
RUNNING = 'running'
PAUSED = 'paused'       # DO_STOP: axes halted, mission waits for resume

MANUAL_ALLOWED = (IDLE, PAUSED, OFFLINE)

STOP_STATE = 'DO_STOP'
RUN_STATE = 'RUN'


class ExecutiveState(object):
    """Fold root status and state text into a mode. Times are seconds of one clock (ROS time)."""

    def __init__(self, now, grace=3.0, stale=7.0):
        self.created = now
        self.grace = grace          # heartbeat every 2 s: silence this long at start = no executive
        self.stale = stale          # silence this long after messages = executive gone
        self.root_active = None     # list of the root container's active states
        self.root_time = None
        self.text = ''
        self.text_time = None
        self._text_mode = None
        self._seq = 0
        self._root_seq = -1
        self._text_seq = -1
        self.last_seen = None

    def update_root(self, active_states, now):
        self.root_active = [s for s in active_states]
        self.root_time = now
        self.seen(now)
        self._seq += 1
        self._root_seq = self._seq

    def update_text(self, text, now):
        self.text = text
        self.text_time = now
        self._seq += 1
        self._text_seq = self._seq
        if text.startswith(STOP_STATE + ': axes halted'):
            self._text_mode = PAUSED
        elif text.startswith(STOP_STATE + ': mission resumed') or text.startswith('START:'):
            self._text_mode = RUNNING
        else:
            self._text_mode = None

    def seen(self, now):
        """Any introspection message of the executive (keeps it from looking offline)."""
        if self.last_seen is None or now > self.last_seen:
            self.last_seen = now

    def mode(self, now):
        last = self.last_seen
        if last is None:
            return UNKNOWN if now - self.created < self.grace else OFFLINE
        if now - last > self.stale:
            return OFFLINE
        if self.root_active is None:
            return UNKNOWN
        active = [s for s in self.root_active if s not in ('None', '')]
        if STOP_STATE in active:
            root_mode = PAUSED
        elif active:
            root_mode = RUNNING
        else:
            root_mode = IDLE
        if self._text_mode is not None and self._text_seq > self._root_seq and root_mode in (RUNNING, PAUSED):
            return self._text_mode
        return root_mode

    def manual_allowed(self, now):
        """(allowed, reason): manual motion only when paused (DO_STOP) or no mission is running."""
        mode = self.mode(now)
        if mode in MANUAL_ALLOWED:
            return True, {IDLE: 'executive idle', PAUSED: 'mission paused (DO_STOP)',
                          OFFLINE: 'no executive running'}[mode]
        if mode == RUNNING:
            return False, 'refused: a mission is running; press EMERGENCY STOP (pause) first'
        return False, 'refused: executive state not known yet'

    def stop_confirmed(self, now):
        return self.mode(now) == PAUSED
