"""Ground truth of the simulated plant factory (pure logic, no rospy).

The world follows the robot's joints (URDF names, ground truth from the simulated controller),
the suction valve and the shear:

* suction seals on a hanging fruit when the valve is open and the right suction tcp is within
  `seal_tolerance` of the fruit surface point nearest to it (| |tcp - centre| - radius |); the
  held fruit then moves with the tcp (translation only: it keeps hanging upright);
* a shear close with the left shear tcp within `cut_tolerance` of a fruit's peduncle
  (centre + (0, 0, radius + 0.01), moving with the fruit) cuts it: held -> HARVESTED,
  not held -> DROPPED (falls to the floor, counted as damaged produce);
* a shear close with the tcp inside a fruit body -> DAMAGED (the fruit is cut);
* a held fruit still on its pedicel pulled more than `tear_distance` from where it hung is torn
  off -> DAMAGED;
* closing the valve releases the held fruit: HARVESTED -> COLLECTED, HELD -> back to HANGING
  at its place on the plant, DAMAGED (off the plant) -> falls to the floor;
* `lose_vacuum` (the vacuum_loss fault): the held fruit drops off the suction sleeve: off the
  plant (cut or torn) -> DROPPED on the floor; still on its pedicel -> back to HANGING. The cup
  seals nothing until the valve has been closed again.

Joint states and shear closes arrive on different topics, so their order is not guaranteed: a
stamped shear close waits until a joint state stamped at or after it has come (then none older
is still on its way). The stroke is taken to span the two joint states around its stamp, from a
short history (`TOOL_HISTORY`): it cuts where the shear stood at the last one at or before the
stamp if a peduncle is within reach there, else where it stood at the first one after. (Only the
first one after was used before; on a busy machine joint states come a simulated second apart
at 20x, and that one showed the left arm already on its way home: the shear "closed on nothing"
40-118 mm from the peduncle it had been servoed to, and the box move tore the fruit off. Only
the one before misses a close commanded right after a move, between two joint states.) A close
with no joint state before it in the history is judged with the latest pose, as one that
`flush_cuts` gives up waiting for.

The valve has the same race: opened once the arm is at the fruit, its message can overtake the
last joint states of the move. A valve opened with a stamp (world_node: the ROS time it arrived)
therefore seals only with a joint state stamped at or after it: on a busy machine the cup had
sealed on a neighbour the approach had swept past (the latest joint state was from mid-move),
and the pull then tore that fruit off.

Its closing has the mirror race: the valve closed (a release) and the next move commanded at
once, the move's joint states can reach the world before the closing. The controller stamps the
valve's changes (set_valve's `stamp`), so a closing stamped before the joint state that tore the
held fruit off undoes that tear: the fruit was let go still on its pedicel and springs back onto
the plant (a restarted task planner releases the fruit it was pulling and takes the arms home).

A shear close has it too: the cut done, the suction arm carries the fruit to the box at once, and
the joint states of that move can reach the world before the close. A close stamped before the
joint state that tore the held fruit off undoes that tear before it is judged: the fruit was
still on its pedicel where the shear closed. (Without it, the shear was judged to close on
nothing where that peduncle had been, or inside an unripe neighbour beside it: a fresh-clone
`make test` once failed so.) A close that then cuts nothing leaves the fruit to be torn again
by the next joint state.
"""

import collections

import numpy as np

from harvest_sim import scenario as scn

HANGING, HELD, HARVESTED, COLLECTED, DROPPED, DAMAGED = range(6)
STATE_NAMES = ('hanging', 'held', 'harvested', 'collected', 'dropped', 'damaged')
SUCTION_TCP = 'right_suction_tcp'
SHEAR_TCP = 'left_shear_tcp'
#: s of joint-state history kept to judge late shear closes where the arm was at their stamp
TOOL_HISTORY = 5.0


class FruitTruth(object):
    """Live state of one scenario fruit."""

    def __init__(self, index, fruit):
        self.index = index
        self.fruit = fruit                        # scenario.Fruit (static description)
        self.position = fruit.position.copy()     # centre now (map)
        self.state = HANGING
        self.attached = True                      # still on its pedicel
        self.cut_point = None                     # where the pedicel was cut

    @property
    def id(self):
        return self.fruit.id

    @property
    def radius(self):
        return self.fruit.radius

    @property
    def peduncle(self):
        return scn.default_peduncle(self.position, self.fruit.radius)

    @property
    def state_name(self):
        return STATE_NAMES[self.state]


class World(object):
    """Suction, cutting and fruit motion; every method returns a list of event strings."""

    def __init__(self, scenario, geom, seal_tolerance=0.012, cut_tolerance=0.010,
                 tear_distance=0.12):
        self.scenario = scenario
        self.geom = geom
        self.seal_tolerance = float(seal_tolerance)
        self.cut_tolerance = float(cut_tolerance)
        self.tear_distance = float(tear_distance)
        self.fruits = [FruitTruth(i, f) for i, f in enumerate(scenario.fruits)]
        self.joints = {}
        self.joint_stamp = None                   # stamp (s) of the latest joint state
        self.pending_cuts = []                    # stamps of shear closes not applied yet
        #: (stamp, shear tip, suction tcp pose) of recent joint states, oldest first: a shear
        #: close that arrives after newer joint states is judged where the arm was at its stamp
        self.tool_history = collections.deque()
        self.poses = geom.frame_transforms({})
        self.valve_open = False
        self.seal_after = None                    # stamp of the valve's opening (see set_valve)
        self.held = None                          # FruitTruth held by suction
        self.vacuum_lost = False                  # lose_vacuum: no seal until the valve closes
        self.hold_offset = None                   # fruit centre in the suction tcp frame
        #: (joint stamp, state before) of the held fruit's tear off its pedicel: a valve closing
        #: stamped before it (come late) undoes the tear
        self.torn = None
        self.seal_events = 0
        self.cut_events = 0
        self.version = 0                          # bumped on every change of fruit state/pose
        self.state_version = 0                    # bumped on state changes only

    # ------------------------------------------------------------------ inputs
    def set_joints(self, joints, stamp=None):
        """New joint positions {URDF name: value} (missing joints keep their last value);
        stamp (s) applies the shear closes stamped up to it."""
        self.joints.update(joints)
        self.poses = self.geom.frame_transforms(self.joints)
        if stamp is not None:
            self.joint_stamp = float(stamp)
            self.tool_history.append((self.joint_stamp, self.tcp(SHEAR_TCP),
                                      self.poses[SUCTION_TCP].copy()))
            while self.tool_history and \
                    self.tool_history[0][0] < self.joint_stamp - TOOL_HISTORY:
                self.tool_history.popleft()
        events = self._move_held()
        due = [t for t in self.pending_cuts if stamp is None or t <= stamp]
        if due:
            self.pending_cuts = [t for t in self.pending_cuts if t not in due]
            for t in due:
                events += self._cut_at(t)
        return events

    def _move_held(self):
        events = []
        if self.held is not None:
            pose = self.poses[SUCTION_TCP]
            new = pose[:3, 3] + pose[:3, :3].dot(self.hold_offset)
            if np.any(np.abs(new - self.held.position) > 1e-7):
                self.held.position = new
                self.version += 1
            if self.held.attached and np.linalg.norm(
                    self.held.position - self.held.fruit.position) > self.tear_distance:
                self.torn = (self.joint_stamp, self.held.state)
                self.held.attached = False
                self.held.cut_point = None
                self.held.state = DAMAGED
                self.state_version += 1
                events.append('%s torn off its pedicel (pulled more than %.0f mm)'
                              % (self.held.id, self.tear_distance * 1000))
        elif self.valve_open and not self.vacuum_lost and self._pose_after_valve():
            events += self._try_seal()
        return events

    def _pose_after_valve(self):
        """True when the tool pose is one the valve's opening may act on: the valve was opened
        without a stamp, or the latest joint state is stamped at or after its opening."""
        return self.seal_after is None or (self.joint_stamp is not None and
                                           self.joint_stamp >= self.seal_after)

    def set_valve(self, is_open, stamp=None):
        """Suction valve opened (True) or closed (False); `stamp` (s): when it changed. Opened
        with a stamp, the cup seals only once a joint state stamped at or after it is here;
        closed with a stamp before the joint state that tore the held fruit off its pedicel, the
        fruit is let go as it was before that pull (back on the plant)."""
        is_open = bool(is_open)
        if is_open == self.valve_open:
            return []
        self.valve_open = is_open
        if is_open:
            self.seal_after = None if stamp is None else float(stamp)
            return [] if self.vacuum_lost or not self._pose_after_valve() else self._try_seal()
        self.seal_after = None
        self.vacuum_lost = False
        return self._release(stamp)

    def lose_vacuum(self):
        """The vacuum_loss fault: the held fruit drops off the suction sleeve (off the plant:
        DROPPED, on the floor; still on its pedicel: back on the plant) and the cup seals
        nothing until the valve has been closed again."""
        f = self.held
        self.vacuum_lost = self.valve_open
        if f is None:
            return ['vacuum lost: the suction held nothing']
        self.held, self.hold_offset, self.torn = None, None, None
        self.version += 1
        self.state_version += 1
        if f.attached:
            if f.state == HELD:
                f.state = HANGING          # a damaged fruit stays damaged
            f.position = f.fruit.position.copy()
            return ['vacuum lost: %s slipped off the suction sleeve, back on its pedicel' % f.id]
        f.state = DROPPED
        f.position = np.array([f.position[0], f.position[1], f.radius])
        return ['vacuum lost: %s dropped off the suction sleeve to the floor' % f.id]

    def shear_cut(self, stamp=None):
        """One shear close. Applied now if stamp is None; with a stamp, judged with the last
        joint state stamped at or before it once one stamped at or after it is here (a message
        can come late on a busy machine, when the arm has moved on), else queued until then
        (see flush_cuts)."""
        if stamp is None:
            return self._cut()
        stamp = float(stamp)
        if self.joint_stamp is not None and self.joint_stamp >= stamp:
            return self._cut_at(stamp)
        self.pending_cuts.append(stamp)
        return []

    def _cut_at(self, stamp):
        """A shear close at `stamp`: where the tools were at the last joint state stamped at or
        before it when that reaches a peduncle, else at the first one after it (the latest pose
        when the history holds none before it)."""
        events = self._undo_tear_before(stamp, 'the shear closed')
        before = after = None
        for t, tip, suction in self.tool_history:
            if t <= stamp:
                before = (tip, suction)
            else:
                after = (tip, suction)
                break
        if before is None:
            return events + self._cut()
        if after is None or self._reaches_peduncle(*before):
            return events + self._cut(*before)
        return events + self._cut(*after)

    def _undo_tear_before(self, stamp, what):
        """Undo the held fruit's tear when `what` happened at `stamp`, before the joint state
        that tore it off (their messages came in the other order): the fruit is on its pedicel
        again, in the state it had. Events (empty when there was no such tear)."""
        torn, f = self.torn, self.held
        if (torn is None or stamp is None or torn[0] is None or f is None or
                float(stamp) >= torn[0] or f.attached or f.cut_point is not None):
            return []
        self.torn = None
        f.attached, f.state = True, torn[1]
        self.version += 1
        self.state_version += 1
        return ['%s: %s at %.3f s, before the pull that tore it off (%.3f s): not torn'
                % (f.id, what, float(stamp), torn[0])]

    def _reaches_peduncle(self, tip, suction):
        """A fruit's peduncle (the held one where `suction` puts it) within the shear's reach."""
        for f in self.fruits:
            if f.state not in (HANGING, HELD):
                continue
            centre = f.position
            if f is self.held:
                centre = suction[:3, 3] + suction[:3, :3].dot(self.hold_offset)
            if np.linalg.norm(tip - scn.default_peduncle(centre, f.radius)) <= self.cut_tolerance:
                return True
        return False

    def flush_cuts(self, now, max_wait):
        """Apply queued shear closes older than max_wait (s) with the latest joints."""
        events = []
        for t in [t for t in self.pending_cuts if now - t >= max_wait]:
            self.pending_cuts.remove(t)
            events += self._cut()
        return events

    def _cut(self, tip=None, suction=None):
        """Shear close with the shear tip at `tip` and the suction tcp at pose `suction`
        (default: where they are now)."""
        self.cut_events += 1
        tip = self.tcp(SHEAR_TCP) if tip is None else tip
        events = []
        # (fruit, centre, peduncle) of every fruit on the plant, the held one where `suction`
        # put it
        live = []
        for f in self.fruits:
            if f.state not in (HANGING, HELD):
                continue
            centre = f.position
            if suction is not None and f is self.held:
                centre = suction[:3, 3] + suction[:3, :3].dot(self.hold_offset)
            live.append((f, centre, scn.default_peduncle(centre, f.radius)))
        nearest = min(live, key=lambda c: np.linalg.norm(tip - c[2]), default=None)
        if nearest is not None and np.linalg.norm(tip - nearest[2]) <= self.cut_tolerance:
            f, _, peduncle = nearest
            d = np.linalg.norm(tip - peduncle)
            f.attached = False
            f.cut_point = peduncle
            if f is self.held:
                f.state = HARVESTED
                events.append('%s harvested (shear %.1f mm from the peduncle)' % (f.id, d * 1000))
            else:
                f.state = DROPPED
                f.position = np.array([f.position[0], f.position[1], f.radius])
                events.append('%s cut without suction: dropped (shear %.1f mm from the peduncle)'
                              % (f.id, d * 1000))
            self.version += 1
            self.state_version += 1
        for f, centre, _ in live:
            if f.state in (HANGING, HELD) and np.linalg.norm(tip - centre) < f.radius:
                f.state = DAMAGED
                events.append('%s damaged: shear closed inside the fruit' % f.id)
                self.version += 1
                self.state_version += 1
        if not events:
            if nearest is None:
                events.append('shear closed on nothing')
            else:
                offset = tip - nearest[2]
                events.append('shear closed on nothing (nearest peduncle: %s, %.1f mm, offset %s mm)'
                              % (nearest[0].id, np.linalg.norm(offset) * 1000,
                                 np.round(offset * 1000, 1).tolist()))
        return events

    # ------------------------------------------------------------------ internals
    def tcp(self, frame):
        return self.poses[frame][:3, 3].copy()

    def _try_seal(self):
        tcp = self.tcp(SUCTION_TCP)
        best, best_d = None, None
        for f in self.fruits:
            if f.state not in (HANGING, DAMAGED) or not f.attached:
                continue
            d = abs(np.linalg.norm(tcp - f.position) - f.radius)
            if best is None or d < best_d:
                best, best_d = f, d
        if best is None or best_d > self.seal_tolerance:
            return []
        self.held, self.torn = best, None
        self.hold_offset = self.poses[SUCTION_TCP][:3, :3].T.dot(best.position - tcp)
        if best.state == HANGING:
            best.state = HELD
        self.seal_events += 1
        self.version += 1
        self.state_version += 1
        return ['%s sealed by suction (%.1f mm from its surface)' % (best.id, best_d * 1000)]

    def _release(self, stamp=None):
        f = self.held
        if f is None:
            return []
        torn = self.torn
        if self._undo_tear_before(stamp, 'valve closed'):
            # the closing came after the joint state that tore the fruit off, stamped before it
            self.held, self.hold_offset = None, None
            f.position = f.fruit.position.copy()
            if f.state == HELD:
                f.state = HANGING
            return ['%s released uncut before the pull that tore it off (valve closed at %.3f s, '
                    'tear at %.3f s): back on the plant, not torn' % (f.id, float(stamp), torn[0])]
        self.torn = None
        self.held, self.hold_offset = None, None
        self.version += 1
        self.state_version += 1
        if f.state == HARVESTED:
            f.state = COLLECTED
            return ['%s collected (released at %s)' % (f.id, np.round(f.position, 3).tolist())]
        if f.state == HELD:
            f.state = HANGING
            f.position = f.fruit.position.copy()
            return ['%s released uncut: back on the plant' % f.id]
        if not f.attached:
            f.position = np.array([f.position[0], f.position[1], f.radius])
            return ['%s released off the plant: fell to the floor' % f.id]
        return ['%s released' % f.id]

    # ------------------------------------------------------------------ outputs
    @property
    def sealed(self):
        return self.held is not None

    def summary(self):
        """Counts for tests and benchmarks."""
        counts = dict((name, 0) for name in STATE_NAMES)
        for f in self.fruits:
            counts[STATE_NAMES[f.state]] += 1
        counts['held_now'] = 1 if self.held is not None else 0
        counts['total'] = len(self.fruits)
        counts['ripe'] = sum(1 for f in self.fruits if f.fruit.ripe)
        counts['ripe_reachable'] = sum(1 for f in self.fruits
                                       if f.fruit.ripe and f.fruit.reachable)
        counts['collected_ripe'] = sum(1 for f in self.fruits
                                       if f.state == COLLECTED and f.fruit.ripe)
        counts['collected_unripe'] = counts['collected'] - counts['collected_ripe']
        counts['seal_events'] = self.seal_events
        counts['cut_events'] = self.cut_events
        return counts
