"""Sense layer, vision: stereo head and hand camera capture, tomato detection and the image_processing action server."""

# the generated modules (vision_pkg.cfg) live in the devel/install space: merge both halves of
# the package whichever comes first on sys.path (as catkin's generated __init__ does)
from pkgutil import extend_path  # noqa: E402

__path__ = extend_path(__path__, __name__)
