"""Manual operation: jog goals from the current joint states and the robot.yaml limits (no rospy)."""
ARMS = ('left', 'right')                      # MoveRobot `arm`: True = left (cutting), False = right
ARM_JOINTS = ('lift', 'boom', 'forearm')      # MoveRobot target_joint.positions order
WAIST_JOINT = 'waist_joint'                   # robot.yaml axis `waist`, joint_states / URDF name


def jog_joint_names():
    return ['%s_%s_joint' % (arm, j) for arm in ARMS for j in ARM_JOINTS]


def limits_from_robot_yaml(robot):
    """{joint name: (min, max)} of the six arm joints, from the parsed robot.yaml dict."""
    lim = robot['robot']['joint_limits']
    out = {}
    for arm in ARMS:
        for j in ARM_JOINTS:
            out['%s_%s_joint' % (arm, j)] = (float(lim[j]['min']), float(lim[j]['max']))
    waist = robot['robot'].get('waist')
    if waist is not None and 'waist' in robot.get('axes', ()):
        out[WAIST_JOINT] = (float(waist['min']), float(waist['max']))
    return out


def waist_jog_target(delta, positions, limits):
    """(target angle, note) of a waist jog from joint_states; ValueError as jog_goal."""
    if delta != delta or delta in (float('inf'), float('-inf')):
        raise ValueError('jog step must be a finite number')
    if WAIST_JOINT not in positions:
        raise ValueError('no joint_states for %s yet' % WAIST_JOINT)
    target = float(positions[WAIST_JOINT]) + delta
    lo, hi = limits.get(WAIST_JOINT, (float('-inf'), float('inf')))
    if target < lo or target > hi:
        target = min(max(target, lo), hi)
        return target, '%s clamped to its limit %.3f' % (WAIST_JOINT, target)
    return target, ''


def split_joint(name):
    """'left_boom_joint' -> ('left', 1)."""
    parts = name.split('_')
    if len(parts) != 3 or parts[0] not in ARMS or parts[1] not in ARM_JOINTS or parts[2] != 'joint':
        raise ValueError('not a jog joint: %r' % name)
    return parts[0], ARM_JOINTS.index(parts[1])


def jog_goal(joint, delta, positions, limits):
    """Goal of a jog: (arm_is_left, [lift, boom, forearm], note).

    positions: {joint name: current position} from joint_states; the arm's other joints keep
    their current values. The moved joint is clamped to its limits (note says so). Raises
    ValueError when a joint state is missing or the delta is not finite.
    """
    arm, index = split_joint(joint)
    if delta != delta or delta in (float('inf'), float('-inf')):
        raise ValueError('jog step must be a finite number')
    names = ['%s_%s_joint' % (arm, j) for j in ARM_JOINTS]
    missing = [n for n in names if n not in positions]
    if missing:
        raise ValueError('no joint_states for %s yet' % ', '.join(missing))
    goal = [float(positions[n]) for n in names]
    target = goal[index] + delta
    lo, hi = limits.get(joint, (float('-inf'), float('inf')))
    note = ''
    if target < lo or target > hi:
        target = min(max(target, lo), hi)
        note = '%s clamped to its limit %.3f' % (joint, target)
    goal[index] = target
    return arm == 'left', goal, note
