"""Where the detection benchmark finds its configuration, rospy-free: the package directory (rospkg,
else the source tree), the detector (config/image_processing.yaml's `stereo_detection`) and the
StereoBM parameters (config/stereo_image_proc.yaml). Used by vision_pkg.bench.
"""
import os

import yaml

from vision_pkg.detection import TomatoDetector


def _package_dir():
    try:
        import rospkg
        return rospkg.RosPack().get_path('vision_pkg')
    except Exception:       # rospkg missing or package not on ROS_PACKAGE_PATH: source tree
        return os.path.abspath(os.path.join(os.path.dirname(__file__), '..', '..'))


def load_stereo_params(path=None):
    path = path or os.path.join(_package_dir(), 'config', 'stereo_image_proc.yaml')
    with open(path) as handle:
        return yaml.load(handle, Loader=yaml.SafeLoader)


def load_detector(path=None):
    path = path or os.path.join(_package_dir(), 'config', 'image_processing.yaml')
    with open(path) as handle:
        cfg = yaml.load(handle, Loader=yaml.SafeLoader) or {}
    return TomatoDetector(**cfg.get('stereo_detection', {}))
