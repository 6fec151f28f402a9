"""The detection benchmark's labelled real photographs, rospy-free: the label YAML loader (a circle
u, v, r, a stage and the visible fraction per fruit; a malformed file is a LabelError naming the
field), the default photo folder (../shared/data/real-tomato-photos beside the workspace) and
the photometric variants of a photo that the robustness figures use (--photo-variants).
Used by vision_pkg.bench.
"""
import math
import os

import cv2
import numpy as np
import yaml

from vision_pkg.bench_config import _package_dir
from vision_pkg.detection import STAGE_NAMES

STAGE_BY_NAME = {name: k for k, name in enumerate(STAGE_NAMES)}


class LabelError(ValueError):
    """A malformed label file: `FILE: field.path: problem`."""


def load_labels(path):
    """{photo file name: [dict(u, v, r, stage (index), visible)]} of a label YAML."""
    try:
        with open(path) as handle:
            data = yaml.load(handle, Loader=yaml.SafeLoader)
    except (OSError, yaml.YAMLError) as exc:
        raise LabelError('%s: %s' % (path, exc))
    if not isinstance(data, dict) or not isinstance(data.get('photos'), dict):
        raise LabelError('%s: photos: missing or not a mapping' % path)
    out = {}
    for name, photo in data['photos'].items():
        fruits = (photo or {}).get('fruits') if isinstance(photo, dict) else None
        if not isinstance(fruits, list):
            raise LabelError('%s: photos.%s.fruits: missing or not a list' % (path, name))
        items = []
        for k, fruit in enumerate(fruits):
            where = '%s: photos.%s.fruits[%d]' % (path, name, k)
            if not isinstance(fruit, dict):
                raise LabelError('%s: not a mapping' % where)
            try:
                u, v, r = (float(fruit[key]) for key in ('u', 'v', 'r'))
                visible = float(fruit.get('visible', 1.0))
            except (KeyError, TypeError, ValueError) as exc:
                raise LabelError('%s: u, v, r (numbers) and visible: %s' % (where, exc))
            if not all(math.isfinite(x) for x in (u, v, r, visible)) or r <= 0 or \
                    not 0.0 <= visible <= 1.0:
                raise LabelError('%s: u, v finite, r > 0, 0 <= visible <= 1' % where)
            stage = STAGE_BY_NAME.get(fruit.get('stage'))
            if stage is None:
                raise LabelError('%s.stage: %r is not one of %s' % (
                    where, fruit.get('stage'), ', '.join(STAGE_NAMES)))
            items.append(dict(u=u, v=v, r=r, stage=stage, visible=visible,
                              id='%s#%d' % (name, k)))
        out[str(name)] = items
    return out


def default_photo_dir():
    """../shared/data/real-tomato-photos beside the workspace (None when absent)."""
    workspace = os.path.abspath(os.path.join(_package_dir(), '..', '..'))
    path = os.path.join(os.path.dirname(workspace), 'shared', 'data', 'real-tomato-photos')
    return path if os.path.isdir(path) else None


#: Photometric variants of every photo for the robustness figures (bench_detection
#: --photo-variants): what another camera, its settings or the light do to the same scene.
#: (name, (kind, value)); gains are (B, G, R) factors.
PHOTO_VARIANTS = (
    ('as taken', ('none', None)),
    ('warm cast', ('gains', (0.75, 0.95, 1.2))),        # incandescent / sodium, white balance off
    ('cool cast', ('gains', (1.2, 1.0, 0.8))),          # shade, overcast sky
    ('LED pink cast', ('gains', (1.15, 0.8, 1.15))),    # red/blue plant-factory LEDs
    ('green cast', ('gains', (0.9, 1.15, 0.9))),        # light through the canopy
    ('under-exposed', ('exposure', 0.6)),
    ('over-exposed', ('exposure', 1.3)),
    ('gamma 0.8', ('gamma', 0.8)),
    ('gamma 1.25', ('gamma', 1.25)),
    ('JPEG quality 40', ('jpeg', 40)),
    ('out of focus', ('blur', 1.5)),                    # Gaussian sigma [px at 1024 wide]
)


def photo_variant(image, kind, value):
    """A BGR uint8 image under one photometric variant (PHOTO_VARIANTS), as a new uint8 image
    of the same size; kind 'none' returns the image itself."""
    if kind == 'none':
        return image
    if kind == 'gains':
        return np.clip(image.astype(np.float32) * np.float32(value), 0, 255).astype(np.uint8)
    if kind == 'exposure':
        return np.clip(image.astype(np.float32) * float(value), 0, 255).astype(np.uint8)
    if kind == 'gamma':
        lut = np.clip(np.round(255.0 * (np.arange(256) / 255.0) ** float(value)), 0, 255)
        return cv2.LUT(image, lut.astype(np.uint8))
    if kind == 'jpeg':
        ok, data = cv2.imencode('.jpg', image, [cv2.IMWRITE_JPEG_QUALITY, int(value)])
        if not ok:
            raise ValueError('JPEG encoding failed')
        return cv2.imdecode(data, cv2.IMREAD_COLOR)
    if kind == 'blur':
        return cv2.GaussianBlur(image, (0, 0), float(value))
    raise ValueError('unknown photo variant %r' % (kind,))
