"""Disk cache of the renderer's baked background textures (numpy only, no rospy).

Baking the canopy, film, floor and roof textures costs a camera node about 1.4 s of CPU at
start, the same every time for one scenario: thousands of anti-aliased leaflets. The textures
depend only on the scenario (seed, lighting, look) and on the code that paints them, so they
are kept in a cache directory under a key made of both, and a later start (the other camera,
the next launch, the next test) loads them in milliseconds.

- Directory: `$HARVEST_SIM_CACHE` if set (empty: no cache), else
  `$XDG_CACHE_HOME/harvest_sim` (`~/.cache/harvest_sim`).
- Key: SHA-1 of the painting code's source (render_background.py, render_materials.py), the
  numpy and OpenCV versions, and the caller's inputs; a change to any of them is a new entry.
- Files are written whole to a temporary name and renamed, so a reader never sees half a file
  and two processes may write the same entry at once. A file that cannot be read (truncated,
  foreign) is ignored and baked again; a directory that cannot be written only costs the time.
- At most `MAX_ENTRIES` files are kept, the least recently written go first.
"""

import hashlib
import os
import tempfile
import zipfile

import numpy as np

ENV = 'HARVEST_SIM_CACHE'
MAX_ENTRIES = 40
_SOURCES = ('render_background.py', 'render_materials.py')
_code_digest = None


def cache_dir():
    """The cache directory, or None when caching is off (`HARVEST_SIM_CACHE=`)."""
    value = os.environ.get(ENV)
    if value is not None:
        return value or None
    base = os.environ.get('XDG_CACHE_HOME') or os.path.join(os.path.expanduser('~'), '.cache')
    return os.path.join(base, 'harvest_sim')


def code_digest():
    """Digest of the code that paints the textures and of the libraries it paints with; ''
    when the sources cannot be read (then nothing is cached: a key could not follow them)."""
    global _code_digest
    if _code_digest is None:
        import cv2       # the caller has it loaded already (it paints with it)
        h = hashlib.sha1()
        here = os.path.dirname(os.path.abspath(__file__))
        try:
            for name in _SOURCES:
                with open(os.path.join(here, name), 'rb') as f:
                    h.update(f.read())
        except OSError:
            _code_digest = ''
            return _code_digest
        h.update(('numpy %s opencv %s' % (np.__version__, cv2.__version__)).encode())
        _code_digest = h.hexdigest()
    return _code_digest


def entry_key(*inputs):
    """Cache key of a bake from `inputs` (plain values, keyed by their repr); None when the
    painting code's source cannot be read (load and store then do nothing)."""
    code = code_digest()
    if not code:
        return None
    h = hashlib.sha1(code.encode())
    for item in inputs:
        h.update(repr(item).encode())
        h.update(b'\0')
    return h.hexdigest()


def load(key, names):
    """The arrays `names` stored under key, or None (no entry, caching off, unreadable)."""
    directory = cache_dir()
    if directory is None or key is None:
        return None
    path = os.path.join(directory, key + '.npz')
    try:
        with np.load(path, allow_pickle=False) as data:
            return [data[n] for n in names]      # each read is a new array: no copy
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return None


def store(key, arrays):
    """Store the named arrays (a dict) under key; False if the cache could not take them."""
    directory = cache_dir()
    if directory is None or key is None:
        return False
    tmp = None
    try:
        os.makedirs(directory, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix='.' + key, suffix='.tmp', dir=directory)
        with os.fdopen(fd, 'wb') as f:
            np.savez(f, **arrays)
        os.replace(tmp, os.path.join(directory, key + '.npz'))
        tmp = None
        _prune(directory)
        return True
    except OSError:
        return False
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass


def _prune(directory):
    entries = []
    for name in os.listdir(directory):
        if name.endswith('.npz'):
            path = os.path.join(directory, name)
            try:
                entries.append((os.path.getmtime(path), path))
            except OSError:
                pass                # removed by another process meanwhile
    for _, path in sorted(entries)[:max(0, len(entries) - MAX_ENTRIES)]:
        try:
            os.unlink(path)
        except OSError:
            pass
