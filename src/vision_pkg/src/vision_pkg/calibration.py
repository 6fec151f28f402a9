"""Camera calibration files (the standard ROS camera_calibration YAML format), rospy-free.

Debian ships no Python camera_info_manager, so single_eye_image_capture reads the calibration
file itself with these helpers. The format is the one written by camera_calibration /
camera_calibration_parsers::writeCalibrationYml: image_width, image_height, camera_name,
camera_matrix, distortion_model, distortion_coefficients, rectification_matrix,
projection_matrix (each matrix as {rows, cols, data}).
"""
import os

import yaml


class CalibrationError(Exception):
    """The calibration URL or file cannot be used."""


def resolve_url(url, package_path=None):
    """Turn a camera_info_url (file://..., package://pkg/..., or a plain path) into a path.

    package_path: callable(package_name) -> directory, used for package:// URLs.
    Returns '' for an empty URL (no calibration).
    """
    if not url:
        return ''
    if url.startswith('file://'):
        return url[len('file://'):]
    if url.startswith('package://'):
        rest = url[len('package://'):]
        pkg, _, rel = rest.partition('/')
        if not pkg or not rel:
            raise CalibrationError('malformed package URL %r (want package://PKG/PATH)' % url)
        if package_path is None:
            raise CalibrationError('cannot resolve %r without a package resolver' % url)
        return os.path.join(package_path(pkg), rel)
    if '://' in url:
        raise CalibrationError('unsupported camera_info_url scheme in %r (use file:// or package://)'
                               % url)
    return url


def _matrix(doc, key, rows, cols, default):
    entry = doc.get(key)
    if entry is None:
        return list(default)
    data = entry.get('data') if isinstance(entry, dict) else entry
    if data is None:
        return list(default)
    data = [float(v) for v in data]
    if rows is not None and len(data) != rows * cols:
        raise CalibrationError('%s has %d values, expected %d' % (key, len(data), rows * cols))
    return data


def parse_calibration(text):
    """Parse calibration YAML text into a dict with CameraInfo field names."""
    try:
        doc = yaml.load(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as exc:
        raise CalibrationError('calibration YAML does not parse: %s' % exc)
    if not isinstance(doc, dict):
        raise CalibrationError('calibration YAML is not a mapping')
    try:
        width = int(doc['image_width'])
        height = int(doc['image_height'])
    except (KeyError, TypeError, ValueError):
        raise CalibrationError('calibration YAML needs integer image_width and image_height')
    k = _matrix(doc, 'camera_matrix', 3, 3, [0.0] * 9)
    if k[0] <= 0.0 or k[4] <= 0.0:
        raise CalibrationError('camera_matrix must have positive fx and fy')
    d = _matrix(doc, 'distortion_coefficients', None, None, [])
    r = _matrix(doc, 'rectification_matrix', 3, 3, [1, 0, 0, 0, 1, 0, 0, 0, 1])
    p = _matrix(doc, 'projection_matrix', 3, 4,
                [k[0], k[1], k[2], 0.0, k[3], k[4], k[5], 0.0, k[6], k[7], k[8], 0.0])
    return {
        'camera_name': str(doc.get('camera_name', '')),
        'width': width,
        'height': height,
        'distortion_model': str(doc.get('distortion_model', 'plumb_bob')),
        'D': d,
        'K': k,
        'R': r,
        'P': p,
    }


def load_calibration(path):
    """Read and parse a calibration file; CalibrationError with the path when it fails."""
    try:
        with open(path, 'r') as handle:
            text = handle.read()
    except (IOError, OSError) as exc:
        raise CalibrationError('cannot read calibration file %s: %s' % (path, exc))
    try:
        return parse_calibration(text)
    except CalibrationError as exc:
        raise CalibrationError('%s: %s' % (path, exc))


def default_calibration(width, height, hfov_rad):
    """An ideal pinhole calibration for a camera of the given size and horizontal FOV."""
    import math
    f = (width / 2.0) / math.tan(hfov_rad / 2.0)
    cx = (width - 1) / 2.0
    cy = (height - 1) / 2.0
    return {
        'camera_name': 'uncalibrated',
        'width': int(width),
        'height': int(height),
        'distortion_model': 'plumb_bob',
        'D': [0.0] * 5,
        'K': [f, 0.0, cx, 0.0, f, cy, 0.0, 0.0, 1.0],
        'R': [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        'P': [f, 0.0, cx, 0.0, 0.0, f, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
    }
