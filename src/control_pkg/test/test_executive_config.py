"""The executive's defaults live only in config/executive.yaml (control_pkg.executive_node)."""
import math
import os

import pytest

from control_pkg import executive_node

YAML = os.path.join(os.path.dirname(__file__), '..', 'config', 'executive.yaml')


def test_defaults_come_from_the_package_yaml():
    assert os.path.samefile(executive_node.defaults_path(), YAML)
    defaults = executive_node.load_defaults()
    for key in ('base_frame', 'server_wait_timeout', 'peduncle_gap', 'left_approach_standoff',
                'right_pulls', 'pull_clearance', 'cut_clearance', 'relocate_tolerance', 'actions',
                'timeouts', 'retries', 'home', 'collection_box_right', 'self_test_components',
                'schedule', 'overlap_margin', 'concurrent_arm_moves'):
        assert key in defaults, key
    assert not hasattr(executive_node, 'DEFAULTS'), 'no second copy of the defaults in code'


def test_the_default_schedule_is_the_papers():
    assert executive_node.load_defaults()['schedule'] == 'paper'
    assert executive_node.merged_config({'schedule': 'pipelined'})['schedule'] == 'pipelined'


def test_overrides_merge_one_level_deep():
    cfg = executive_node.merged_config({'timeouts': {'kinematics': 2.0}, 'peduncle_gap': 0.02})
    defaults = executive_node.load_defaults()
    assert cfg['timeouts']['kinematics'] == 2.0
    assert cfg['timeouts']['move_robot'] == defaults['timeouts']['move_robot']
    assert cfg['peduncle_gap'] == 0.02
    assert cfg['actions'] == defaults['actions']


@pytest.mark.parametrize('overrides, field', [
    ({'home': {'left': [0.0, math.nan, 2.0]}}, 'home/left'),
    ({'right_pulls': [[-0.08, 0.0]]}, 'right_pulls'),
    ({'cut_clearance': -0.01}, 'cut_clearance'),
    ({'relocate_tolerance': math.inf}, 'relocate_tolerance'),
    ({'relocate_radius_tolerance': 1.5}, 'relocate_radius_tolerance'),
    ({'schedule': 'fast'}, 'schedule'),
    ({'overlap_margin': -0.01}, 'overlap_margin'),
])
def test_bad_overrides_are_refused_naming_the_field(overrides, field):
    with pytest.raises(ValueError, match=field):
        executive_node.merged_config(overrides)


def test_a_defaults_file_that_is_not_a_mapping_is_refused(tmp_path):
    bad = tmp_path / 'executive.yaml'
    bad.write_text('- just a list\n')
    with pytest.raises(ValueError, match='must be a mapping'):
        executive_node.load_defaults(str(bad))
