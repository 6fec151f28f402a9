"""Which ROS nodes are alive, dead or missing (no rospy).

alive   registered with the master and answering (getPid over XML-RPC)
dead    registered but not answering (killed without unregistering), or seen earlier this
        session and now gone
missing expected (config/dashboard.yaml) and never seen
"""
ALIVE, DEAD, MISSING = 'alive', 'dead', 'missing'


class NodeRow(object):
    def __init__(self, name, state, expected, detail=''):
        self.name = name
        self.state = state
        self.expected = expected
        self.detail = detail


class NodeHealth(object):
    def __init__(self, expected=()):
        self.expected = set(self._norm(n) for n in expected)
        self.seen = set()
        self.rows = {}

    @staticmethod
    def _norm(name):
        return name if name.startswith('/') else '/' + name

    def update(self, registered, answers):
        """registered: node names known to the master; answers: {name: (ok, detail)} for those pinged.

        Returns the rows sorted by name.
        """
        registered = set(registered)
        rows = {}
        for name in registered:
            ok, detail = answers.get(name, (False, 'not pinged'))
            if ok:
                self.seen.add(name)
            rows[name] = NodeRow(name, ALIVE if ok else DEAD, name in self.expected, detail)
        for name in self.seen - registered:
            rows[name] = NodeRow(name, DEAD, name in self.expected, 'unregistered (gone)')
        for name in self.expected - registered - self.seen:
            rows[name] = NodeRow(name, MISSING, True, 'expected, never seen')
        self.rows = rows
        return [rows[n] for n in sorted(rows)]

    def forget(self, name):
        """Forget a dead node that is not expected (like rosnode cleanup, locally)."""
        self.seen.discard(name)
        self.rows.pop(name, None)

    def state(self, name):
        row = self.rows.get(self._norm(name))
        return row.state if row else None
