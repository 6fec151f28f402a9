"""Start, stop and restart ROS nodes from the dashboard (the paper's node module), no rospy, no Qt.

The ROS side is a `layer` object (dashboard/node_layer.py in the window, a fake in the tests):
  layer.kill(name)             -> (ok, detail)          rosnode.kill_nodes
  layer.pid(name)              -> pid or None           the master's URI + getPid (None: not alive)
  layer.spec(name)             -> NodeSpec or None, why the node's command line (and its roslaunch)
  layer.launch(spec)           -> process handle        roslaunch.scriptapi.ROSLaunch + roslaunch.core.Node
  layer.stop_process(handle)   -> None                  stop a process this dashboard launched

A node this dashboard launched is restarted from the spec it was launched with. Another node is
restarted only when its package and type can be found (refused otherwise, before anything is
killed); when its launch respawns it, the dashboard waits for the new process instead of starting
a second one.
"""
import os
import shlex

OK, REFUSED, FAILED = 'ok', 'refused', 'failed'


class NodeSpec(object):
    """What roslaunch needs to start a node again."""

    def __init__(self, name, package, node_type, namespace='/', args='', remaps=(), respawn=False):
        self.name = name                    # full name, e.g. /robot/motion_server
        self.package = package
        self.node_type = node_type
        self.namespace = namespace
        self.args = args
        self.remaps = list(remaps)
        self.respawn = bool(respawn)

    @property
    def base_name(self):
        return self.name.rstrip('/').rsplit('/', 1)[-1]

    def __repr__(self):
        return 'NodeSpec(%s: %s/%s ns=%s args=%r remaps=%r respawn=%s)' % (
            self.name, self.package, self.node_type, self.namespace, self.args, self.remaps, self.respawn)


def norm(name):
    return name if name.startswith('/') else '/' + name


def namespace_of(name):
    """'/robot/motion_server' -> '/robot/'; '/motion_server' -> '/'."""
    ns = norm(name).rsplit('/', 1)[0]
    return ns + '/' if ns else '/'


def find_package_dir(path, is_package_dir):
    """The nearest directory above `path` for which is_package_dir(dir) holds (a package.xml), or None."""
    d = os.path.dirname(os.path.abspath(path))
    while d and d != os.path.dirname(d):
        if is_package_dir(d):
            return d
        d = os.path.dirname(d)
    return None


#: options of roslaunch and rostest whose value is the next word of the command line
_VALUE_OPTIONS = frozenset((
    '-p', '--port', '-w', '--numworkers', '-t', '--timeout', '--pid', '-u', '--server_uri',
    '--run_id', '--master-logger-level', '--sigint-timeout', '--sigterm-timeout', '--args',
    '--results-filename', '--results-base-dir', '--time-limit'))
LAUNCHERS = ('roslaunch', 'rostest')


def launch_arguments(argv):
    """(launch words, name:=value args) of a roslaunch or rostest command line: the words name
    the launch files as roslaunch takes them ([package] file ...); options and their values are
    left out (catkin's run_tests runs `rostest --results-filename NAME --results-base-dir DIR
    FILE`). ([], []) when argv is neither."""
    starts = [i for i, a in enumerate(argv[:2]) if os.path.basename(a) in LAUNCHERS]
    if not starts:
        return [], []
    words, args, skip = [], [], False
    for a in argv[starts[0] + 1:]:
        if skip:
            skip = False
        elif a.startswith('-'):
            skip = a in _VALUE_OPTIONS          # '--opt=value' carries its value
        elif ':=' in a:
            args.append(a)
        else:
            words.append(a)
    return words, args


def spec_from_cmdline(name, argv, package_of):
    """NodeSpec from a node process's argv, or (None, why).

    argv: the process's command line (a python script: [interpreter, script, args...]; a binary:
    [binary, args...]); package_of(path) -> package name or None for the executable's path.
    Special `__name:=`/`__log:=`/`__ns:=` arguments are dropped (roslaunch sets them again),
    `from:=to` become remaps, the rest are the node's args.
    """
    if not argv:
        return None, 'no command line for %s (not on this machine?)' % name
    exe_index = 0
    first = os.path.basename(argv[0])
    if first.startswith('python') and len(argv) > 1:
        exe_index = 1
    exe = argv[exe_index]
    package = package_of(exe)
    if not package:
        return None, '%s: %s is not inside a ROS package' % (name, exe)
    args, remaps = [], []
    for arg in argv[exe_index + 1:]:
        if ':=' in arg:
            key, value = arg.split(':=', 1)
            if not key.startswith('__'):
                remaps.append((key, value))
        else:
            args.append(arg)
    return NodeSpec(norm(name), package, os.path.basename(exe), namespace_of(name),
                    ' '.join(shlex.quote(a) for a in args), remaps), ''


class NodeController(object):
    """The node module's decisions. Every method returns (status, text) for the UI and the mission
    event; `wait_back(name, old_pid)` is supplied by the caller (bounded wait for a respawn)."""

    def __init__(self, layer):
        self.layer = layer
        self.launched = {}          # name -> (spec, process handle) of nodes this dashboard started
        self.specs = {}             # name -> spec seen at a stop, so a stopped node can be started again

    def known_spec(self, name):
        name = norm(name)
        if name in self.launched:
            return self.launched[name][0], ''
        if name in self.specs:
            return self.specs[name], ''
        return self.layer.spec(name)

    def stop(self, name):
        name = norm(name)
        if self.layer.pid(name) is None and name not in self.launched:
            return REFUSED, '%s is not running' % name
        spec, _why = self.known_spec(name)
        if spec is not None:
            self.specs[name] = spec
        ok, detail = self.layer.kill(name)
        own = self.launched.pop(name, None)
        if own is not None:
            self.layer.stop_process(own[1])
        if spec is not None and spec.respawn and own is None:
            return (OK if ok else FAILED), '%s killed (%s); its launch respawns it' % (name, detail)
        return (OK if ok else FAILED), '%s %s' % (name, 'stopped' if ok else 'not stopped: %s' % detail)

    def start_plan(self, name):
        """(spec, None) of a stopped node that can be started, or (None, refusal text)."""
        name = norm(name)
        if self.layer.pid(name) is not None:
            return None, '%s is already running' % name
        spec, why = self.known_spec(name)
        if spec is None:
            return None, 'cannot start %s: %s' % (name, why or 'its package and type are unknown')
        return spec, None

    def start(self, name):
        spec, refusal = self.start_plan(name)
        if spec is None:
            return REFUSED, refusal
        return self._launch(spec)

    def launch(self, spec):
        """Start `spec` (the GUI thread: roslaunch's process monitor wants the main thread)."""
        return self._launch(spec)

    def _launch(self, spec):
        try:
            handle = self.layer.launch(spec)
        except Exception as exc:  # noqa: BLE001 - roslaunch raises many kinds; the text goes to the UI
            return FAILED, 'could not start %s (%s/%s): %s' % (spec.name, spec.package, spec.node_type, exc)
        self.launched[spec.name] = (spec, handle)
        return OK, '%s started (%s/%s)' % (spec.name, spec.package, spec.node_type)

    def restart_plan(self, name):
        """Before killing anything: (spec, None) or (None, refusal text)."""
        name = norm(name)
        spec, why = self.known_spec(name)
        if spec is None:
            return None, 'restart of %s refused: %s; stop it and start it by hand' % (
                name, why or 'its package and type are unknown')
        return spec, None

    def restart(self, name, wait_back):
        """Kill and bring back. Runs in a worker thread apart from the final launch, which
        restart() leaves to `launch` (roslaunch wants the GUI/main thread): returns
        (status, text, spec to launch or None)."""
        name = norm(name)
        spec, refusal = self.restart_plan(name)
        if spec is None:
            return REFUSED, refusal, None
        old_pid = self.layer.pid(name)
        own = self.launched.pop(name, None)
        if old_pid is not None or own is not None:
            ok, detail = self.layer.kill(name)
            if own is not None:
                self.layer.stop_process(own[1])
            if not ok and own is None:
                return FAILED, 'restart of %s: kill failed: %s' % (name, detail), None
        if spec.respawn and own is None:
            if wait_back(name, old_pid):
                return OK, '%s restarted (respawned by its launch)' % name, None
            return FAILED, '%s killed but its launch did not respawn it in time' % name, None
        return OK, '%s killed; starting it again' % name, spec

    def shutdown(self):
        for name, (_spec, handle) in list(self.launched.items()):
            self.layer.stop_process(handle)
        self.launched = {}
