"""The ROS side of node_control: rosnode's and roslaunch's Python APIs, the master, /proc.

Where a running node's package and type come from: the master gives the node's URI, getPid its
process; on this machine /proc/<pid>/cmdline gives the executable (its package is the nearest
directory with a package.xml, named by that manifest) and its arguments and remaps. When the parent
process is a roslaunch, its launch files are read (roslaunch.config) for the node's `respawn`
and its exact package/type/args. A node on another machine (no /proc entry) cannot be restarted.
"""
import os

try:
    import xmlrpc.client as xmlrpclib
except ImportError:  # pragma: no cover - Python 2
    import xmlrpclib

import rosgraph
import rospy

from visualization_pkg.dashboard.node_control import (NodeSpec, find_package_dir, launch_arguments,
                                                      spec_from_cmdline)
from visualization_pkg.dashboard.shell_session import DefaultSigintForChildren


def _read_proc(pid, what):
    try:
        with open('/proc/%d/%s' % (int(pid), what), 'rb') as f:
            return f.read()
    except (IOError, OSError, ValueError):
        return None


def proc_cmdline(pid):
    raw = _read_proc(pid, 'cmdline')
    return [a.decode('utf-8', 'replace') for a in raw.split(b'\0') if a] if raw else []


def proc_parent(pid):
    raw = _read_proc(pid, 'stat')
    if not raw:
        return None
    try:
        return int(raw[raw.rindex(b')') + 2:].split()[1])
    except (ValueError, IndexError):
        return None


def _manifest_name(pkg_dir):
    try:
        import xml.etree.ElementTree as ET
        return ET.parse(os.path.join(pkg_dir, 'package.xml')).getroot().findtext('name').strip()
    except Exception:  # noqa: BLE001 - unreadable or bad manifest: no package
        return None


def package_of(path):
    """Package name of an executable path (devel/lib/<pkg>/x, src/<pkg>/scripts/x, /opt/ros/...)."""
    real = os.path.realpath(path)
    d = find_package_dir(real, lambda p: os.path.isfile(os.path.join(p, 'package.xml')))
    if d:
        return _manifest_name(d)
    parts = real.split(os.sep)
    if 'lib' in parts:                          # <prefix>/lib/<pkg>/<exe>: catkin's libexec layout
        i = len(parts) - 1 - parts[::-1].index('lib')
        if i + 2 == len(parts) - 1:
            return parts[i + 1]
    return None


class RosNodeLayer(object):
    """rosnode/roslaunch for NodeController. launch() and stop_process() run in the GUI thread."""

    def __init__(self, caller_id, ping_timeout=0.5):
        self.caller_id = caller_id
        self.ping_timeout = ping_timeout
        self._launch = None

    def _uri(self, name):
        try:
            return rosgraph.Master(self.caller_id).lookupNode(name)
        except (rosgraph.MasterError, IOError, OSError):
            return None

    def pid(self, name):
        from visualization_pkg.dashboard.nodes_panel import _TimeoutTransport
        uri = self._uri(name)
        if not uri:
            return None
        try:
            code, _msg, pid = xmlrpclib.ServerProxy(uri, transport=_TimeoutTransport(self.ping_timeout)).getPid(
                self.caller_id)
            return int(pid) if code == 1 else None
        except Exception:  # noqa: BLE001 - any socket/XML-RPC failure = not alive
            return None

    def kill(self, name):
        import rosnode
        try:
            success, fail = rosnode.kill_nodes([name])
        except Exception as exc:  # noqa: BLE001 - rosnode raises ROSNodeIOException and others
            return False, str(exc)
        return name in success, 'killed' if name in success else 'rosnode could not kill it'

    def spec(self, name):
        pid = self.pid(name)
        if pid is None:
            return None, '%s is not running, and the dashboard never saw its command line' % name
        argv = proc_cmdline(pid)
        if not argv:
            return None, '%s runs on another machine (pid %d not here)' % (name, pid)
        spec, why = spec_from_cmdline(name, argv, package_of)
        launched = self._from_roslaunch(name, proc_parent(pid))
        if launched is not None:
            return launched, ''
        return spec, why

    @staticmethod
    def _from_roslaunch(name, parent_pid):
        """The node as its roslaunch parent's launch files declare it (respawn included), or None."""
        argv = proc_cmdline(parent_pid) if parent_pid else []
        words, args = launch_arguments(argv)
        if not words:
            return None
        try:
            import roslaunch.config
            import roslaunch.rlutil
            import roslaunch.xmlloader
            files = roslaunch.rlutil.resolve_launch_arguments(words)
            config = roslaunch.config.ROSLaunchConfig()
            loader = roslaunch.xmlloader.XmlLoader()
            for launch_file in files:
                loader.load(launch_file, config, argv=['roslaunch'] + args, verbose=False)
        except Exception as exc:  # noqa: BLE001 - the launch may have changed on disk; fall back
            rospy.logdebug('dashboard: cannot read the launch of %s: %s', name, exc)
            return None
        for node in config.nodes:
            full = rosgraph.names.ns_join(node.namespace, node.name)
            if full == name:
                return NodeSpec(name, node.package, node.type, node.namespace, node.args or '',
                                node.remap_args, node.respawn)
        return None

    def launch(self, spec):
        import roslaunch.core
        import roslaunch.scriptapi
        with DefaultSigintForChildren():      # roslaunch stops a node with SIGINT first
            if self._launch is None:
                self._launch = roslaunch.scriptapi.ROSLaunch()
                self._launch.start()
            node = roslaunch.core.Node(spec.package, spec.node_type, name=spec.base_name,
                                       namespace=spec.namespace, args=spec.args,
                                       remap_args=list(spec.remaps), output='log')
            return self._launch.launch(node)

    def stop_process(self, handle):
        try:
            handle.stop()
        except Exception as exc:  # noqa: BLE001 - already gone
            rospy.logdebug('dashboard: stopping a launched node: %s', exc)

    def shutdown(self):
        if self._launch is not None:
            self._launch.stop()
            self._launch = None
