"""Decode and describe SMACH userdata from the introspection status (`local_data`).

`local_data` is base64 text of a protocol-2 pickle of the userdata dict (smach_ros on Noetic and
control_pkg's fallback server). Unpickling data from the network can run arbitrary code, so this
decoder only builds plain Python values, ROS messages (modules named `<pkg>.msg._<Type>`) and
genpy times; any other class becomes an `Opaque` stand-in that just keeps its state for display.
"""
import base64
import binascii
import importlib
import io
import pickle
import re

_SAFE_BUILTINS = {
    ('builtins', 'set'), ('builtins', 'frozenset'), ('builtins', 'list'), ('builtins', 'dict'),
    ('builtins', 'tuple'), ('builtins', 'bytearray'), ('builtins', 'complex'), ('builtins', 'slice'),
    ('builtins', 'range'), ('builtins', 'object'), ('builtins', 'bytes'), ('builtins', 'str'),
    ('builtins', 'int'), ('builtins', 'float'), ('builtins', 'bool'),
    ('__builtin__', 'set'), ('__builtin__', 'frozenset'), ('__builtin__', 'list'), ('__builtin__', 'dict'),
    ('__builtin__', 'tuple'), ('__builtin__', 'object'), ('__builtin__', 'bytearray'),
    ('copy_reg', '_reconstructor'), ('copyreg', '_reconstructor'),
    ('collections', 'OrderedDict'), ('collections', 'deque'),
}
_MSG_MODULE = re.compile(r'^[A-Za-z_][\w]*\.msg\._[A-Za-z_]\w*$')
_TIME_CLASSES = {('genpy.rostime', 'Time'), ('genpy.rostime', 'Duration'),
                 ('rospy.rostime', 'Time'), ('rospy.rostime', 'Duration')}


class Opaque(object):
    """A value of a class the decoder does not build; keeps what the pickle gave it."""
    _module = '?'
    _name = '?'

    def __new__(cls, *args, **kwargs):
        obj = object.__new__(cls)
        obj.args = args
        obj.state = None
        return obj

    def __init__(self, *args, **kwargs):
        pass

    def __setstate__(self, state):
        self.state = state

    def __repr__(self):
        return '<%s.%s>' % (self._module, self._name)


def _opaque_class(module, name):
    return type(str(name), (Opaque,), {'_module': module, '_name': name})


class _Unpickler(pickle.Unpickler):
    def find_class(self, module, name):
        if (module, name) in _SAFE_BUILTINS or (module, name) in _TIME_CLASSES \
                or _MSG_MODULE.match(module):
            try:
                if module == '__builtin__':
                    module = 'builtins'
                elif module == 'copy_reg':
                    module = 'copyreg'
                mod = importlib.import_module(module)
                return getattr(mod, name)
            except (ImportError, AttributeError):
                pass
        return _opaque_class(module, name)


def decode(text):
    """local_data text -> (dict, error text or ''). Never raises."""
    if not text:
        return {}, ''
    try:
        blob = base64.b64decode(text)
    except (binascii.Error, ValueError, TypeError) as exc:
        return {}, 'not base64: %s' % exc
    try:
        data = _Unpickler(io.BytesIO(blob), encoding='latin1').load()
    except Exception as exc:  # noqa: BLE001 - any malformed pickle is reported, not raised
        return {}, 'cannot unpickle userdata: %s' % exc
    if not isinstance(data, dict):
        return {'(value)': data}, ''
    return data, ''


def _is_message(value):
    return hasattr(value, '__slots__') and hasattr(value, '_type') and hasattr(value, '_slot_types')


def _is_time(value):
    return hasattr(value, 'secs') and hasattr(value, 'nsecs') and hasattr(value, 'to_sec')


def describe(value, max_items=20, max_depth=6):
    """A display tree of a value: (summary text, [(key, subtree), ...]).

    Messages show their fields, sequences their first `max_items` elements, dicts their items.
    """
    if max_depth <= 0:
        return _short(value), []
    if _is_time(value):
        return '%.3f s' % value.to_sec(), []
    if _is_message(value):
        kids = [(slot, describe(getattr(value, slot, None), max_items, max_depth - 1))
                for slot in value.__slots__]
        return value._type, kids
    if isinstance(value, dict):
        items = sorted(value.items(), key=lambda kv: str(kv[0]))
        kids = [(str(k), describe(v, max_items, max_depth - 1)) for k, v in items[:max_items]]
        if len(items) > max_items:
            kids.append(('...', ('%d more' % (len(items) - max_items), [])))
        return 'dict (%d)' % len(items), kids
    if isinstance(value, (list, tuple, set, frozenset)):
        seq = list(value)
        if seq and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in seq) and len(seq) <= 12:
            return '[%s]' % ', '.join(_num(v) for v in seq), []
        kids = [('[%d]' % i, describe(v, max_items, max_depth - 1)) for i, v in enumerate(seq[:max_items])]
        if len(seq) > max_items:
            kids.append(('...', ('%d more' % (len(seq) - max_items), [])))
        return '%s (%d)' % (type(value).__name__, len(seq)), kids
    if isinstance(value, Opaque):
        kids = []
        if isinstance(value.state, dict):
            kids = [(str(k), describe(v, max_items, max_depth - 1)) for k, v in sorted(value.state.items())]
        return repr(value), kids
    return _short(value), []


def _num(v):
    return ('%.4g' % v) if isinstance(v, float) else str(v)


def _short(value, limit=120):
    if isinstance(value, float):
        return _num(value)
    text = repr(value)
    return text if len(text) <= limit else text[:limit - 3] + '...'
