"""The one place where control_pkg gets SMACH from.

Every other control_pkg module writes::

    from control_pkg.smach_compat import smach, SimpleActionState, IntrospectionServer

and never imports ``smach`` or ``smach_ros`` itself.

What this module fixes
----------------------
The SMACH core on this platform is PyPI ``standalone-smach`` 0.0.9 (the SMACH 2.5.0 API).
Its ``Concurrence.execute`` waits for its child threads with ``Thread.isAlive()``, which
Python 3.9 removed (upstream SMACH 2.5.1 switched to ``is_alive()``). On Python 3.11 every
Concurrence therefore dies with AttributeError once its children have finished.

Why the fix looks the way it does
---------------------------------
The least invasive repair is to change only what ``smach.concurrence`` sees as ``threading``:
that module's global name ``threading`` is rebound to a small proxy whose ``Thread`` is a
subclass with ``isAlive = is_alive``; every other attribute (Condition, Event, ...) is the
real ``threading`` one. So

- only threads created by Concurrence get the alias; ``threading.Thread`` itself and every
  other library stay untouched (no global monkey-patch of the standard library);
- no SMACH source is copied or edited, and a later SMACH that already calls ``is_alive()``
  is left alone: the patch is applied only if ``Concurrence.execute`` really names
  ``isAlive`` (checked on its code object and the comprehensions inside it), so it is a
  no-op on a fixed SMACH;
- it is idempotent (importing this module twice patches once).

On Python 3.8 (Noetic) ``isAlive`` still exists but warns on every call; the alias there
avoids the DeprecationWarning flood from Concurrence's wait loop.

smach_ros or the fallback
-------------------------
``SimpleActionState`` and ``IntrospectionServer`` come from ``smach_ros`` when it
imports (a Noetic robot PC), else from ``control_pkg.smach_ros_compat``, which has the
same constructor signatures and behaviour. The choice is made once, by really importing
smach_ros: a smach_ros that is installed but broken (a missing dependency, or
``roslib.load_manifest`` failing because it is not on the ROS package path) raises
something, which is logged as one warning line before the fallback is used; it does not
stop the node. Both names always come from the same layer. ``HAVE_SMACH_ROS`` tells which
one (True: smach_ros). All three are resolved lazily (PEP 562 module ``__getattr__``), so
importing ``smach`` from here needs neither rospy nor a ROS build: pure decision logic and
its pytest tests stay ROS-free. Loading either ROS layer routes SMACH's log output to
rospy (its info lines at DEBUG level: ``_quiet_transitions``) and its shutdown check to
``rospy.is_shutdown``.
"""
import importlib
import threading

import smach
import smach.concurrence

__all__ = ['smach', 'SimpleActionState', 'IntrospectionServer', 'HAVE_SMACH_ROS',
           'CONCURRENCE_PATCHED']

class _AliveAliasThread(threading.Thread):
    """A Thread that also answers the pre-3.9 spelling ``isAlive()``."""

    def isAlive(self):  # noqa: N802 (the name SMACH 2.5.0 calls)
        return self.is_alive()


class _ConcurrenceThreading(object):
    """What ``smach.concurrence`` sees as ``threading``: the real module except Thread."""

    Thread = _AliveAliasThread

    def __getattr__(self, name):
        return getattr(threading, name)


def _code_names(code):
    """Every name a code object uses, nested comprehensions included."""
    names = set(code.co_names)
    for const in code.co_consts:
        if hasattr(const, 'co_names'):
            names |= _code_names(const)
    return names


def _patch_concurrence():
    """Give Concurrence's child threads ``isAlive``; return True if a patch is in place."""
    module = smach.concurrence
    if isinstance(module.threading, _ConcurrenceThreading):
        return True
    if 'isAlive' not in _code_names(module.Concurrence.execute.__code__):
        return False  # this SMACH already uses is_alive()
    module.threading = _ConcurrenceThreading()
    return True


CONCURRENCE_PATCHED = _patch_concurrence()

_ROS_NAMES = ('SimpleActionState', 'IntrospectionServer')
_FALLBACK = 'control_pkg.smach_ros_compat'
_layer_lock = threading.Lock()


def _warn(text):
    """One warning line through rospy (stderr before init_node), else Python logging."""
    try:
        import rospy
    except ImportError:  # the fallback needs rospy too and will say so itself
        import logging
        logging.getLogger(__name__).warning(text)
        return
    rospy.logwarn(text)


def _import_smach_ros():
    """The smach_ros module if it imports, else None (one warning if it is there but broken)."""
    try:
        return importlib.import_module('smach_ros')
    except ImportError as exc:
        if getattr(exc, 'name', None) == 'smach_ros':
            return None  # not installed: the fallback is the normal case, nothing to say
        reason = exc
    except Exception as exc:  # a broken install raises anything: rospkg, roslib, ...
        reason = exc
    _warn('control_pkg.smach_compat: smach_ros is installed but cannot be imported (%s: %s); '
          'using %s instead' % (type(reason).__name__, ' '.join(str(reason).split()), _FALLBACK))
    return None


def _load_ros_layer():
    """Decide once between smach_ros and the fallback; bind the lazy names here."""
    with _layer_lock:
        if 'HAVE_SMACH_ROS' not in globals():
            layer = _import_smach_ros()
            have = layer is not None
            if not have:
                layer = importlib.import_module(_FALLBACK)
            for name in _ROS_NAMES:
                globals()[name] = getattr(layer, name)
            globals()['HAVE_SMACH_ROS'] = have
            _quiet_transitions()


def _quiet_transitions():
    """SMACH's info lines (one per transition, and at every container start one listing its
    userdata) go to rospy's DEBUG level; warnings and errors stay. Each line costs about
    0.5 ms on the task planner's path between two action states (measured: the executive
    overhead of a pipelined mission fell from 5.8 to 2.5 ms median), and the transitions are
    on the introspection topics and in the executive's own events anyway."""
    import rospy
    smach.set_loggers(rospy.logdebug, rospy.logwarn, rospy.logdebug, rospy.logerr)


def __getattr__(name):
    """Load the ROS layer (smach_ros or the fallback) on first use of one of its names."""
    if name not in _ROS_NAMES and name != 'HAVE_SMACH_ROS':
        raise AttributeError("module %r has no attribute %r" % (__name__, name))
    _load_ros_layer()
    return globals()[name]
