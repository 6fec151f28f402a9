"""The robot description: the committed robot.yaml is valid, and the committed URDF is exactly
what the generator makes of it (edit robot.yaml, then run scripts/generate_urdf)."""
import os
import shutil
import subprocess

import pytest

from harvest_description import robot_config
from harvest_description.urdf_generator import urdf_from_yaml

PKG = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ROBOT_YAML = os.path.join(PKG, 'config', 'robot.yaml')
URDF = os.path.join(PKG, 'urdf', 'harvest_robot.urdf')


def test_committed_robot_yaml_is_valid():
    config = robot_config.load(ROBOT_YAML)
    assert robot_config.problems(config) == []


def test_committed_urdf_is_generated_from_robot_yaml():
    with open(URDF) as f:
        assert f.read() == urdf_from_yaml(ROBOT_YAML), \
            'urdf/harvest_robot.urdf is stale: run rosrun harvest_description generate_urdf'


def test_a_bad_robot_yaml_stops_the_generator_with_one_line(tmp_path):
    bad = tmp_path / 'robot.yaml'
    with open(ROBOT_YAML) as f:
        bad.write_text(f.read().replace('boom: ', 'boom: .nan #', 1))
    out = subprocess.run([os.path.join(PKG, 'scripts', 'generate_urdf'), '--config', str(bad),
                          '--output', str(tmp_path / 'x.urdf')], capture_output=True, text=True)
    assert out.returncode != 0
    assert str(bad) in out.stderr and len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert not (tmp_path / 'x.urdf').exists()


@pytest.mark.skipif(shutil.which('check_urdf') is None, reason='liburdfdom-tools not installed')
def test_urdf_parses_with_urdfdom():
    out = subprocess.run(['check_urdf', URDF], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr


def _with_fruit_radius(radii):
    import yaml
    with open(ROBOT_YAML) as f:
        config = yaml.safe_load(f)
    config['robot']['arms']['right']['fruit_radius'] = radii
    return config


@pytest.mark.parametrize('radii, problem', [
    ({'min': 0.03, 'max': 0.02}, 'min 0.03 must be < max 0.02'),
    ({'min': 0.0, 'max': 0.05}, 'min must be > 0'),
    ({'min': float('nan'), 'max': 0.05}, 'NaN'),
    ({'max': 0.05}, 'missing'),
])
def test_a_bad_suction_sleeve_fruit_radius_is_named(radii, problem):
    problems = robot_config.problems(_with_fruit_radius(radii))
    assert any(field.startswith('robot.arms.right.fruit_radius') and problem in text
               for field, text in problems), problems


def test_the_suction_sleeve_fruit_radius_is_optional():
    config = _with_fruit_radius(None)
    del config['robot']['arms']['right']['fruit_radius']
    assert robot_config.problems(config) == []
