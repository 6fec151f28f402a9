"""sensor_msgs/Image data -> an RGB888 numpy array for display (no rospy, no cv_bridge)."""
import numpy as np

_CHANNELS = {'rgb8': 3, 'bgr8': 3, 'rgba8': 4, 'bgra8': 4, 'mono8': 1, '8UC1': 1, '8UC3': 3,
             '8UC4': 4, 'mono16': 1, '16UC1': 1, '32FC1': 1}


class UnsupportedEncoding(ValueError):
    pass


def to_rgb(encoding, height, width, step, data, max_width=None):
    """Return an (h, w, 3) uint8 C-contiguous array. Depth images are scaled to 0..255.

    `max_width`: subsample by an integer factor so the result is at most this wide.
    """
    if encoding not in _CHANNELS:
        raise UnsupportedEncoding('unsupported image encoding %r' % encoding)
    ch = _CHANNELS[encoding]
    dtype = {'mono16': '>u2', '16UC1': '<u2', '32FC1': '<f4'}.get(encoding, np.uint8)
    itemsize = np.dtype(dtype).itemsize
    buf = np.frombuffer(bytes(data) if not isinstance(data, (bytes, bytearray)) else data, dtype=np.uint8)
    if height * step > buf.size or width * ch * itemsize > step:
        raise ValueError('image data too short: %d bytes for %dx%d step %d' % (buf.size, width, height, step))
    rows = buf[:height * step].reshape(height, step)[:, :width * ch * itemsize]
    img = np.ascontiguousarray(rows).view(dtype).reshape(height, width, ch)
    if max_width and width > max_width:
        f = int(np.ceil(width / float(max_width)))
        img = img[::f, ::f]
    if itemsize > 1:
        plane = img[..., 0].astype(np.float32)
        finite = np.isfinite(plane)
        lo = float(plane[finite].min()) if finite.any() else 0.0
        hi = float(plane[finite].max()) if finite.any() else 1.0
        plane = np.where(finite, (plane - lo) * (255.0 / max(hi - lo, 1e-9)), 0.0)
        img = plane.astype(np.uint8)[..., None]
        ch = 1
    if ch == 1:
        out = np.repeat(img, 3, axis=2)
    elif encoding in ('bgr8', '8UC3'):
        out = img[..., ::-1]
    elif encoding in ('bgra8', '8UC4'):
        out = img[..., 2::-1]
    elif encoding == 'rgba8':
        out = img[..., :3]
    else:
        out = img
    return np.ascontiguousarray(out, dtype=np.uint8)
