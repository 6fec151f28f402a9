"""Copies of a configuration (nested dicts and lists, e.g. robot.yaml) with one field changed,
for tests of the validators that read it."""
import copy


def with_value(config, keys, value):
    """A deep copy of `config` with the field at `keys` (a path of dict keys and list indices)
    set to `value`."""
    out = copy.deepcopy(config)
    node = out
    for key in keys[:-1]:
        node = node[key]
    node[keys[-1]] = value
    return out
