"""The move_robot goals per arm (pure bookkeeping, no ROS): the arms a goal belongs to
(goal_arms, goal_scope, waist_settled), who takes over whom (ArmGoals, Displaced), and which
goal-handle calls a thread may make now (split_actions); re-exported by motion_goals."""

ARMS = ('right', 'left')


def goal_arms(left, move_waist):
    """The arms a MoveRobot goal belongs to: its own arm, or both when it turns the waist (the
    waist carries both arms' bases, so a waist goal moves both of them)."""
    if move_waist:
        return ARMS
    return ('left',) if left else ('right',)


def goal_scope(left, names, targets, speeds, waist_settled):
    """(arms, names, targets, speeds) of a valid MoveRobot goal (validate_arm_goal's axes).

    An arm goal that also gives a waist angle (``move_waist``) where the waist already rests
    (``waist_settled``: the caller's verdict, see ``waist_settled``) does not turn the base: the
    waist axis is left out and the goal belongs to its arm alone. Any other waist goal, and a
    waist-only goal always, belongs to both arms (``goal_arms``)."""
    names, targets, speeds = list(names), list(targets), list(speeds)
    if 'waist' not in names:
        return goal_arms(left, False), names, targets, speeds
    if waist_settled and len(names) > 1:
        i = names.index('waist')
        del names[i], targets[i], speeds[i]
        return goal_arms(left, False), names, targets, speeds
    return goal_arms(left, True), names, targets, speeds


def waist_settled(target, position, moving, tolerance, held):
    """True when a waist target needs no move: the waist rests (not ``moving``, no running goal
    ``held`` it) within ``tolerance`` (rad) of ``target``. Unknown position (None): False."""
    if held or moving or position is None:
        return False
    return abs(float(target) - float(position)) <= tolerance


class Displaced(object):
    """A running goal a new one takes over: ``goal`` ends preempted; ``halt`` lists its axes the
    new goal does not command (to halt: nobody would watch them), in the old goal's order."""

    __slots__ = ('goal', 'halt')

    def __init__(self, goal, halt):
        self.goal = goal
        self.halt = halt

    def __repr__(self):
        return 'Displaced(%r, halt=%r)' % (self.goal, self.halt)


class ArmGoals(object):
    """Which running move_robot goal each arm belongs to (pure bookkeeping, no ROS).

    A goal holds one arm, or both (a waist goal). Every arm has at most one goal; a new goal
    takes over the running goals of its arms (they end preempted; those of their axes the new
    goal does not command are halted, the ones it commands are retargeted by its own writes) and
    leaves the other arm's goal alone. Goals are any hashable objects, compared by identity.
    """

    def __init__(self):
        self._arms = {}          # arm name -> goal
        self._axes = {}          # id(goal) -> axis names

    def goals(self):
        """The running goals, each once (right arm's first)."""
        seen = []
        for arm in ARMS:
            goal = self._arms.get(arm)
            if goal is not None and not any(goal is g for g in seen):
                seen.append(goal)
        return seen

    def goal_of(self, arm):
        return self._arms.get(arm)

    def arms_of(self, goal):
        return tuple(a for a in ARMS if self._arms.get(a) is goal)

    def axis_held(self, name):
        """True when a running goal commands axis ``name``."""
        return any(name in axes for axes in self._axes.values())

    def holds(self, goal):
        return any(g is goal for g in self._arms.values())

    def displaced_by(self, arms, axes):
        """What a new goal for ``arms`` commanding ``axes`` would take over (nothing changes)."""
        axes = set(axes)
        out = []
        for arm in arms:
            if arm not in ARMS:
                raise ValueError('unknown arm %r (one of %s)' % (arm, ', '.join(ARMS)))
            old = self._arms.get(arm)
            if old is not None and not any(d.goal is old for d in out):
                out.append(Displaced(old, [a for a in self._axes[id(old)] if a not in axes]))
        return out

    def take_over(self, arms, axes):
        """Remove the goals a new goal for ``arms`` displaces; returns them (``Displaced``).
        An old goal holding both arms ends even when the new goal is for one of them."""
        out = self.displaced_by(arms, axes)
        for d in out:
            self.remove(d.goal)
        return out

    def add(self, goal, arms, axes):
        """Make ``goal`` the running goal of ``arms``; returns what it displaced."""
        out = self.take_over(arms, axes)
        for arm in arms:
            self._arms[arm] = goal
        self._axes[id(goal)] = list(axes)
        return out

    def remove(self, goal):
        """Forget ``goal``; True when it was running (False: already ended or displaced)."""
        arms = self.arms_of(goal)
        for arm in arms:
            del self._arms[arm]
        if arms:
            del self._axes[id(goal)]
        return bool(arms)

    def clear(self):
        """Forget every goal; returns them (each once)."""
        goals = self.goals()
        self._arms.clear()
        self._axes.clear()
        return goals


def split_actions(actions, own):
    """Which goal-handle calls a thread may make now: ``actions`` are (server name, call)
    pairs, ``own`` the server whose callback runs in this thread (holding that server's lock),
    or None (a thread holding no action server lock: the poll thread, a service). Returns
    (now, later): a callback makes only its own server's calls; the others wait for the poll
    thread. Two servers' callbacks each finishing the other's goals would each wait for the
    other's lock for ever."""
    if own is None:
        return [call for _, call in actions], []
    now = [call for key, call in actions if key == own]
    later = [(key, call) for key, call in actions if key != own]
    return now, later
