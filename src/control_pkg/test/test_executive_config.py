"""The executive's defaults live only in config/executive.yaml (control_pkg.executive_node)."""
import ast
import math
import os

import pytest
import yaml

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
    ({'cart_wait': math.nan}, 'cart_wait'),
    ({'cart_wait': -1.0}, 'cart_wait'),
])
def test_bad_overrides_are_refused_naming_the_field(overrides, field):
    with pytest.raises(ValueError, match=field):
        executive_node.merged_config(overrides)


def test_a_defaults_file_that_is_not_a_mapping_is_refused(tmp_path):
    bad = tmp_path / 'executive.yaml'
    bad.write_text('- just a list\n')
    with pytest.raises(ValueError, match='must be a mapping'):
        executive_node.load_defaults(str(bad))


# --- no second copy of a default in the code -------------------------------------------------------
SOURCES = ('executive.py', 'executive_callbacks.py', 'executive_config.py', 'executive_estop.py',
           'executive_node.py', 'executive_pipelined.py', 'executive_plan_states.py',
           'executive_publishers.py', 'executive_states.py', 'executive_stop_states.py')
CONFIG_NAMES = ('cfg', 'config')


def _is_config(node):
    """cfg, config, self.cfg, self.config, context.config, self.context.config ..."""
    if isinstance(node, ast.Name):
        return node.id in CONFIG_NAMES
    return isinstance(node, ast.Attribute) and node.attr in CONFIG_NAMES


def _config_reads(path):
    """(key, how, line) of every read of a top-level config key in the module at `path`."""
    with open(path) as f:
        tree = ast.parse(f.read(), path)
    reads = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Subscript) and _is_config(node.value):
            key = node.slice.value if isinstance(node.slice, ast.Constant) else getattr(
                getattr(node.slice, 'value', None), 'value', None)       # Python 3.8: ast.Index
            reads.append((key, 'item', node.lineno))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and \
                node.func.attr == 'get' and _is_config(node.func.value):
            reads.append((node.args[0].value if node.args else None, 'get', node.lineno))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and \
                node.func.attr == 'get_param' and len(node.args) > 1 and \
                isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str):
            reads.append((node.args[0].value.lstrip('~'), 'get_param', node.lineno))
    return reads


def test_the_executive_reads_its_defaults_only_from_the_yaml():
    defaults = executive_node.load_defaults()
    here = os.path.join(os.path.dirname(os.path.abspath(executive_node.__file__)))
    items = []
    for name in SOURCES:
        for key, how, line in _config_reads(os.path.join(here, name)):
            where = '%s:%d' % (name, line)
            # a default in code (config.get(key, value), get_param('~key', value)) would be a
            # second copy of the YAML's
            assert how == 'item' or key not in defaults, (where, key, how)
            assert how != 'get', (where, key, 'read config[%r]: the YAML has every key' % key)
            if how == 'item' and isinstance(key, str):
                items.append((where, key))
    assert items, 'the executive reads its configuration'
    for where, key in items:
        assert key in defaults, (where, key, 'not in config/executive.yaml')


def test_the_self_test_checks_the_database_on_the_records_topic():
    from control_pkg import names
    path = os.path.join(os.path.dirname(YAML), 'self_test.yaml')
    with open(path) as f:
        components = yaml.safe_load(f)['components']
    database = [c for c in components if c['name'] == 'database']
    assert database and database[0]['topic'] == names.PICK_RECORDS
