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
``SimpleActionState`` and ``IntrospectionServer`` come from ``smach_ros`` when it is
importable (a Noetic robot PC), else from ``control_pkg.smach_ros_compat``, which has the
same constructor signatures and behaviour. They are loaded lazily (PEP 562 module
``__getattr__``), so importing ``smach`` from here needs neither rospy nor a ROS build:
pure decision logic and its pytest tests stay ROS-free. Loading either ROS layer routes
SMACH's log output to rospy and its shutdown check to ``rospy.is_shutdown``.
"""
import importlib
import importlib.util
import threading

import smach
import smach.concurrence

__all__ = ['smach', 'SimpleActionState', 'IntrospectionServer', 'HAVE_SMACH_ROS',
           'CONCURRENCE_PATCHED']

HAVE_SMACH_ROS = importlib.util.find_spec('smach_ros') is not None


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


def __getattr__(name):
    """Load the ROS layer (smach_ros or the fallback) on first use of one of its names."""
    if name not in _ROS_NAMES:
        raise AttributeError("module %r has no attribute %r" % (__name__, name))
    layer = importlib.import_module('smach_ros' if HAVE_SMACH_ROS
                                    else 'control_pkg.smach_ros_compat')
    value = getattr(layer, name)
    globals()[name] = value
    return value
