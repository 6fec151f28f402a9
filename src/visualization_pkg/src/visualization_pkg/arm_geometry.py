"""Points of one SCARA arm for drawing it (mission_markers), from robot.yaml (no rospy).

Frame: `<arm>_arm_base` of the URDF (lift along z, boom and forearm revolute about z; the
forearm axis sits `boom` metres along the boom's x, the tool centre `forearm + tool` metres along
the forearm's x).
"""
import math


class ArmGeometry(object):
    def __init__(self, boom, forearm, tool):
        self.boom = float(boom)
        self.forearm = float(forearm)
        self.tool = float(tool)

    @classmethod
    def from_robot_yaml(cls, robot):
        lengths = robot['robot']['link_lengths']
        return cls(lengths['boom'], lengths['forearm'], lengths['tool'])

    def polyline(self, lift, boom, forearm):
        """[base, lift top, elbow, flange, tool centre] as (x, y, z) in `<arm>_arm_base`."""
        c1, s1 = math.cos(boom), math.sin(boom)
        c12, s12 = math.cos(boom + forearm), math.sin(boom + forearm)
        elbow = (self.boom * c1, self.boom * s1, lift)
        flange = (elbow[0] + self.forearm * c12, elbow[1] + self.forearm * s12, lift)
        tcp = (elbow[0] + (self.forearm + self.tool) * c12, elbow[1] + (self.forearm + self.tool) * s12, lift)
        return [(0.0, 0.0, 0.0), (0.0, 0.0, lift), elbow, flange, tcp]

    def tool_centre(self, lift, boom, forearm):
        return self.polyline(lift, boom, forearm)[-1]
