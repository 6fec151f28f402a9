"""The aggregated diagnostics (diagnostic_aggregator's diagnostics_agg) as a tree (no rospy).

Aggregator names are paths ('/Sense/Motion/Modbus connection'); each path element is a tree
node, and a node's level is its own status level if it has one, else the worst of its children.
"""
OK, WARN, ERROR, STALE = 0, 1, 2, 3
LEVEL_NAMES = {OK: 'OK', WARN: 'WARN', ERROR: 'ERROR', STALE: 'STALE'}


def level_name(level):
    return LEVEL_NAMES.get(level, str(level))


def worse(a, b):
    """The worse of two levels: ERROR > STALE > WARN > OK (stale is not as bad as an error)."""
    rank = {OK: 0, WARN: 1, STALE: 2, ERROR: 3}
    return a if rank.get(a, 3) >= rank.get(b, 3) else b


class DiagNode(object):
    def __init__(self, name, path):
        self.name = name
        self.path = path
        self.level = None
        self.message = ''
        self.hardware_id = ''
        self.values = []
        self.children = {}

    def effective_level(self):
        level = self.level
        for child in self.children.values():
            child_level = child.effective_level()
            level = child_level if level is None else worse(level, child_level)
        return OK if level is None else level


def split_name(name):
    return [p for p in name.strip().split('/') if p]


def build_tree(statuses):
    """statuses: iterable of (name, level, message, hardware_id, [(key, value)]) -> root DiagNode."""
    root = DiagNode('', '')
    for name, level, message, hardware_id, values in statuses:
        parts = split_name(name) or [name or '(unnamed)']
        node = root
        path = ''
        for part in parts:
            path += '/' + part
            node = node.children.setdefault(part, DiagNode(part, path))
        node.level = level
        node.message = message
        node.hardware_id = hardware_id
        node.values = list(values)
    return root


def flatten(node):
    """Every node below `node`, parents before children, children sorted by name."""
    for name in sorted(node.children):
        child = node.children[name]
        yield child
        for sub in flatten(child):
            yield sub
