"""Shared helpers of the harvest_sim pytest tests (paths, robot geometry, tiny scenarios)."""

import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.join(HERE, '..', '..')
if os.path.join(HERE, '..', 'src') not in sys.path:
    sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from harvest_sim import scenario as scn  # noqa: E402
from motion_pkg.kinematics import RobotGeometry  # noqa: E402  (the sourced workspace's)

ROBOT_YAML = os.path.join(SRC, 'harvest_description', 'config', 'robot.yaml')
SCENARIOS = os.path.normpath(os.path.join(HERE, '..', 'scenarios'))
GEOM = RobotGeometry.from_yaml(ROBOT_YAML)


def single_fruit_scenario(position, radius=0.035, ripeness=0.9, leaves=(), stems=(),
                          points=(0.0,), intensity=1.0):
    """A scenario with one fruit and nothing else in front of the canopy."""
    return scn.Scenario('single', scn.Track(list(points)),
                        scn.Lighting(intensity=intensity),
                        [scn.Fruit('f0', position, radius, ripeness, picking_point=0)],
                        stems=list(stems), leaves=list(leaves), seed=1)
