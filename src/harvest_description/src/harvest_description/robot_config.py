"""The one loader and validator of config/robot.yaml (pure: yaml and math, no rospy).

Every reader of robot.yaml (motion_pkg's kinematics and motion server, harvest_sim's world,
cameras and controller, this package's URDF generator, markers and dashboard) loads it with
:func:`load` or checks a parsed copy with :func:`validate`, so a bad file is refused at start
with one line naming the file and the field, e.g.::

    /path/robot.yaml: motion.speed.boom: NaN is not finite

Rules: every number anywhere in the file is finite (and a number, not a string or a bool) and
at most 1e6 in magnitude (no physical value of this robot comes near; a larger one would
overflow to infinity in the readers' arithmetic);
the sections and fields the readers use are there with the right shape; limits are ordered
(min < max); speeds, accelerations, link lengths and the stereo baseline are > 0; durations and
the arm clearance are >= 0; ``axes`` names each controller axis once.
"""

import math

import yaml

ARMS = ('left', 'right')
ARM_JOINTS = ('lift', 'boom', 'forearm')
MOTION_KINDS = ('cart', 'waist') + ARM_JOINTS
AXIS_NAMES = ('cart', 'waist') + tuple('%s_%s' % (a, j) for a in ('right', 'left')
                                       for j in ARM_JOINTS)
DEFAULT_SOURCE = 'robot.yaml'
MAX_MAGNITUDE = 1e6


class RobotConfigError(ValueError):
    """A bad robot.yaml: ``source`` (file), ``field`` (dotted path) and ``problem``; one line."""

    def __init__(self, source, field, problem):
        self.source = source
        self.field = field
        self.problem = problem
        super(RobotConfigError, self).__init__('%s: %s: %s' % (source, field, problem))


def _one_line(text):
    return ' '.join(str(text).split())


def _is_number(value):
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _describe(value):
    if isinstance(value, float) and math.isnan(value):
        return 'NaN'
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + '...'


def _number_problem(value):
    """Why a number (int or float) is unusable, or ''."""
    if isinstance(value, int) and abs(value) > MAX_MAGNITUDE:   # also ints beyond any float
        return '%s is out of range (|value| <= %g)' % (_describe(value), MAX_MAGNITUDE)
    if not math.isfinite(value):
        return '%s is not finite' % _describe(value)
    if abs(value) > MAX_MAGNITUDE:
        return '%s is out of range (|value| <= %g)' % (_describe(value), MAX_MAGNITUDE)
    return ''


def _join(path, key):
    if isinstance(key, int):
        return '%s[%d]' % (path, key)
    return '%s.%s' % (path, key) if path else str(key)


class _Checker(object):
    """Collects (field, problem) pairs in file order; one problem per field."""

    def __init__(self):
        self.found = []
        self._fields = set()

    def report(self, field, problem):
        if field not in self._fields:
            self._fields.add(field)
            self.found.append((field, problem))

    # --- every number in the file ----------------------------------------------------------
    def walk(self, node, path):
        if isinstance(node, dict):
            for key, value in node.items():
                self.walk(value, _join(path, key))
        elif isinstance(node, list):
            for i, value in enumerate(node):
                self.walk(value, _join(path, i))
        elif _is_number(node):
            problem = _number_problem(node)
            if problem:
                self.report(path, problem)

    # --- shapes ----------------------------------------------------------------------------
    def present(self, parent, key, field, optional):
        """True when parent has key; an absent field that is not optional is reported missing."""
        if key in parent:
            return True
        if not optional:
            self.report(field, 'missing')
        return False

    def mapping(self, parent, key, path, optional=False):
        """parent[key] when it is a mapping; None (reported unless optional and absent)."""
        field = _join(path, key)
        if not self.present(parent, key, field, optional):
            return None
        value = parent[key]
        if not isinstance(value, dict):
            self.report(field, 'must be a mapping, got %s' % _describe(value))
            return None
        return value

    def number(self, parent, key, path, minimum=None, positive=False, optional=False):
        """parent[key] as a finite float; None when absent or bad (reported)."""
        field = _join(path, key)
        if not self.present(parent, key, field, optional):
            return None
        value = parent[key]
        if not _is_number(value):
            self.report(field, '%s is not a number' % _describe(value))
            return None
        problem = _number_problem(value)
        if problem:
            self.report(field, problem)
            return None
        if positive and not value > 0.0:
            self.report(field, 'must be > 0, got %s' % _describe(value))
            return None
        if minimum is not None and value < minimum:
            self.report(field, 'must be >= %s, got %s' % (minimum, _describe(value)))
            return None
        return float(value)

    def vector3(self, parent, key, path, optional=False):
        field = _join(path, key)
        if not self.present(parent, key, field, optional):
            return None
        value = parent[key]
        if not isinstance(value, list) or len(value) != 3:
            self.report(field, 'must be a list of 3 numbers, got %s' % _describe(value))
            return None
        items = [self.number(dict(enumerate(value)), i, field) for i in range(3)]
        return None if None in items else items

    def limits(self, parent, key, path):
        """A {min, max} mapping with min < max."""
        section = self.mapping(parent, key, path)
        if section is None:
            return None
        field = _join(path, key)
        lo = self.number(section, 'min', field)
        hi = self.number(section, 'max', field)
        if lo is None or hi is None:
            return None
        if not lo < hi:
            self.report(field, 'min %s must be < max %s' % (_describe(lo), _describe(hi)))
            return None
        return lo, hi

    # --- the file --------------------------------------------------------------------------
    def check(self, config):
        if not isinstance(config, dict):
            self.report('(document)', 'must be a mapping with robot, motion and axes, got %s'
                        % _describe(config))
            return
        self.walk(config, '')
        robot = self.mapping(config, 'robot', '')
        if robot is not None:
            self.check_robot(robot)
        motion = self.mapping(config, 'motion', '')
        if motion is not None:
            self.check_motion(motion)
        self.check_axes(config)

    def check_robot(self, robot):
        p = 'robot'
        track = self.mapping(robot, 'track', p)
        if track is not None:
            axis = self.vector3(track, 'axis', 'robot.track')
            if axis is not None and not any(v != 0.0 for v in axis):
                self.report('robot.track.axis', 'must not be the zero vector')
        self.limits(robot, 'track', p)
        waist = self.mapping(robot, 'waist', p)
        if waist is not None:
            self.number(waist, 'height', 'robot.waist', optional=True)
        self.limits(robot, 'waist', p)
        arms = self.mapping(robot, 'arms', p)
        if arms is not None:
            for arm in ARMS:
                section = self.mapping(arms, arm, 'robot.arms')
                if section is not None:
                    self.vector3(section, 'base_xyz', 'robot.arms.' + arm)
                    self.number(section, 'base_yaw', 'robot.arms.' + arm)
                    if 'fruit_radius' in section:
                        radii = self.limits(section, 'fruit_radius', 'robot.arms.' + arm)
                        if radii is not None and radii[0] <= 0.0:
                            self.report('robot.arms.%s.fruit_radius' % arm,
                                        'min must be > 0, got %s' % _describe(radii[0]))
        lengths = self.mapping(robot, 'link_lengths', p)
        if lengths is not None:
            for key in ('boom', 'forearm', 'tool'):
                self.number(lengths, key, 'robot.link_lengths', positive=True)
        joint_limits = self.mapping(robot, 'joint_limits', p)
        if joint_limits is not None:
            for joint in ARM_JOINTS:
                self.limits(joint_limits, joint, 'robot.joint_limits')
        self.number(robot, 'arm_clearance', p, minimum=0.0)
        camera = self.mapping(robot, 'hand_camera', p)
        if camera is not None:
            self.vector3(camera, 'xyz', 'robot.hand_camera')
            self.vector3(camera, 'rpy', 'robot.hand_camera')
        head = self.mapping(robot, 'stereo_head', p)
        if head is not None:
            self.vector3(head, 'xyz', 'robot.stereo_head')
            self.vector3(head, 'rpy', 'robot.stereo_head')
            self.number(head, 'baseline', 'robot.stereo_head', positive=True)
        # optional and unused: the place pose over the box is the executive's
        # (control_pkg executive.yaml collection_box_right); older files may still carry it
        box = self.mapping(robot, 'collection_box', p, optional=True)
        if box is not None:
            self.vector3(box, 'right_arm_joints', 'robot.collection_box', optional=True)

    def check_motion(self, motion):
        for section_name in ('speed', 'acceleration'):
            section = self.mapping(motion, section_name, 'motion')
            if section is not None:
                for kind in MOTION_KINDS:
                    self.number(section, kind, 'motion.' + section_name, positive=True)
        for key in ('suction_build_up', 'shear_stroke'):
            self.number(motion, key, 'motion', minimum=0.0)

    def check_axes(self, config):
        if 'axes' not in config:
            self.report('axes', 'missing')
            return
        axes = config['axes']
        if not isinstance(axes, list) or not axes:
            self.report('axes', 'must be a non-empty list of axis names, got %s'
                        % _describe(axes))
            return
        seen = set()
        for i, name in enumerate(axes):
            field = _join('axes', i)
            if name not in AXIS_NAMES:
                self.report(field, 'unknown axis %s (known: %s)' % (_describe(name),
                                                                   ', '.join(AXIS_NAMES)))
            elif name in seen:
                self.report(field, 'axis %s listed twice' % name)
            else:
                seen.add(name)


def problems(config):
    """[(field, problem)] of a parsed robot.yaml in file order; empty when it is valid."""
    checker = _Checker()
    checker.check(config)
    return checker.found


def validate(config, source=DEFAULT_SOURCE):
    """Return ``config`` when valid, else raise RobotConfigError for its first problem."""
    found = problems(config)
    if found:
        field, problem = found[0]
        raise RobotConfigError(source, field, _one_line(problem))
    return config


def load(path):
    """Parse and validate robot.yaml at ``path``; RobotConfigError (naming ``path``) when bad."""
    try:
        with open(path) as stream:
            config = yaml.safe_load(stream)
    except (IOError, OSError) as exc:
        raise RobotConfigError(path, '(file)', _one_line('cannot read: %s' % exc))
    except yaml.YAMLError as exc:
        raise RobotConfigError(path, '(file)', _one_line('not valid YAML: %s' % exc))
    return validate(config, path)


def load_or_exit(path, logfatal):
    """:func:`load` for a node at start: on a bad file, ``logfatal`` one line and exit 1.

    ``logfatal`` is e.g. rospy.logfatal (kept out of this module so it stays ROS-free). Raises
    SystemExit(1), which ends the node with a non-zero exit code (``required="true"`` in the
    launch file then stops the whole launch).
    """
    try:
        return load(path)
    except RobotConfigError as exc:
        logfatal('%s' % exc)
        raise SystemExit(1)
