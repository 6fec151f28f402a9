"""Which nodes of the robot restarted, from what the ROS master says of them (rospy-free).

A node that dies and is respawned registers again with the master from a new process, on a new
XML-RPC URI (its server listens on a port of its own). The executive looks the watched nodes up
now and then (executive_node: `~watched_nodes`, `~node_watch_period`) and gives the URIs to a
RestartTracker, which reports every node whose URI changed since it was last seen: each is a
mission event (`restart`, state = the node's name), so the dashboard and the records show every
restart, not only the task planner's own.
"""


class RestartTracker(object):
    """URIs of watched nodes as last seen; `update` reports the nodes registered anew."""

    def __init__(self, names):
        self.names = list(names)
        self._uris = {}

    def update(self, uris):
        """`uris`: {name: URI, or None when the master does not know the node}.

        Returns [(name, old URI, new URI)] of the nodes whose URI changed since they were last
        seen. The first sighting of a node is not a restart; a node the master does not know
        (not started yet, or shut down) keeps its last URI, so its return is judged against it."""
        restarted = []
        for name in self.names:
            uri = uris.get(name)
            if not uri:
                continue
            old = self._uris.get(name)
            if old is not None and old != uri:
                restarted.append((name, old, uri))
            self._uris[name] = uri
        return restarted


def restart_detail(name, old, new):
    """The text of a node's restart event."""
    return 'node %s restarted: registered again from a new process (%s, was %s)' % (name, new, old)
