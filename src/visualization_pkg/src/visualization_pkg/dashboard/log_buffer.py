"""rosout entries, their levels and the console's filters (no rospy)."""
import collections

# rosgraph_msgs/Log levels
DEBUG, INFO, WARN, ERROR, FATAL = 1, 2, 4, 8, 16
LEVEL_NAMES = collections.OrderedDict([(DEBUG, 'DEBUG'), (INFO, 'INFO'), (WARN, 'WARN'),
                                       (ERROR, 'ERROR'), (FATAL, 'FATAL')])


def level_name(level):
    return LEVEL_NAMES.get(level, str(level))


class Entry(object):
    __slots__ = ('stamp', 'level', 'node', 'msg', 'location')

    def __init__(self, stamp, level, node, msg, location=''):
        self.stamp = stamp
        self.level = level
        self.node = node
        self.msg = msg
        self.location = location


class LogFilter(object):
    """min_level: show this level and above; nodes: empty = all, else only these; text: substring."""

    def __init__(self, min_level=DEBUG, nodes=None, text=''):
        self.min_level = min_level
        self.nodes = set(nodes or ())
        self.text = text

    def accepts(self, entry):
        if entry.level < self.min_level:
            return False
        if self.nodes and entry.node not in self.nodes:
            return False
        if self.text and self.text.lower() not in entry.msg.lower() and self.text.lower() not in entry.node.lower():
            return False
        return True


class LogBuffer(object):
    """The last `size` entries and every node name seen."""

    def __init__(self, size=5000):
        self.entries = collections.deque(maxlen=size)
        self.nodes = set()

    def add(self, entry):
        """Add an entry; True when the oldest one was dropped to make room."""
        dropped = len(self.entries) == self.entries.maxlen
        self.entries.append(entry)
        self.nodes.add(entry.node)
        return dropped

    def filtered(self, log_filter):
        return [e for e in self.entries if log_filter.accepts(e)]

    def clear(self):
        self.entries.clear()
