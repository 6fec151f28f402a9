"""Camera and illumination "look" of the simulated cameras (numpy + OpenCV, no rospy).

The renderer (render.py) produces a clean image in display (sRGB-like) encoding, as a perfectly
white-balanced, correctly exposed camera would see the scene. A CameraLook turns it into what a
real colour camera delivers, in this order (a camera blurs before its sensor; here the blur acts
on the demosaiced luma, where it costs a third):

1. illumination and camera colour, per Bayer site: the channel gain = the colour cast the
   illuminant leaves after an imperfect auto white balance (normalised to unit luminance)
   times the exposure (2**EV), on linear light; then the tone curve: gamma on linear light,
   an S-shaped contrast curve and a flare (lifted blacks). One LUT per channel.
2. sensor: a Bayer colour filter mosaic (one colour per pixel, pattern drawn per camera) with
   signal-dependent noise: variance = gain * shot * signal + (gain * read)**2 in linear light,
   carried through the tone curve, so shadows are noisier than highlights and clipped
   highlights are flat (one sigma LUT per channel, a bank of unit-normal noise frames);
3. demosaicing: luma by bilinear interpolation of the mosaic (zipper at edges), colour from
   the 2 x 2 Bayer cells at half resolution (false-colour fringes, colour bleeding as JPEG's
   4:2:0 subsampling);
4. optics on the luma: Gaussian blur (lens, slight defocus; the noise is raised beforehand so
   that its final std is the sensor's) and vignetting (light falls off toward the corners);
5. JPEG: the luma really goes through JPEG at the camera's quality (8 x 8 blocking, ringing,
   lost fine detail).

Geometry is untouched: every step is centred (no shift, no distortion), so a fruit still
renders where the pinhole model puts it.

Parameters are drawn per (scenario seed, camera model) by look_params(), deterministically:
both eyes of a stereo pair are the same camera model, so they share white balance, exposure
and tone (block matching needs the same texture in both eyes); their noise is independent
(noise_bank per eye name). KIND_RANGES and COMMON_RANGES document every range.

Illumination kinds:
  daylight  greenhouse daylight through film: cool/neutral, slightly hazy
  led       plant factory red/blue LED light: pink-magenta cast (green weak)
  warm      warm lamps or low evening sun: orange cast
"""

import math
import zlib
from collections import OrderedDict, namedtuple

import cv2
import numpy as np

from harvest_sim.scenario_model import LOOK_KINDS as KINDS

#: per kind: gains of R and B relative to G (the cast left in the picture) and exposure in EV
KIND_RANGES = OrderedDict([
    ('daylight', OrderedDict([('wb_r', (0.90, 1.04)), ('wb_b', (0.98, 1.14)),
                              ('exposure_ev', (-0.60, 0.20)), ('flare', (0.0, 0.035))])),
    ('led', OrderedDict([('wb_r', (1.80, 2.40)), ('wb_b', (1.60, 2.20)),
                         ('exposure_ev', (-0.50, 0.20)), ('flare', (0.0, 0.02))])),
    ('warm', OrderedDict([('wb_r', (1.06, 1.20)), ('wb_b', (0.72, 0.88)),
                          ('exposure_ev', (-0.40, 0.30)), ('flare', (0.0, 0.02))])),
])
#: ranges shared by every kind
COMMON_RANGES = OrderedDict([
    ('gamma', (0.85, 1.10)),            # exponent on linear light (< 1 lifts the shadows)
    ('contrast', (0.0, 0.25)),          # S-curve strength in the encoded domain
    ('read_noise', (0.0004, 0.0010)),   # read noise std, linear light (1 = full scale)
    ('shot_noise', (0.00015, 0.0005)),   # shot noise variance per unit linear signal
    ('blur_sigma', (0.35, 0.75)),       # px, Gaussian optics/defocus
    ('vignetting', (0.08, 0.28)),       # share of light lost in the image corners
    ('jpeg_quality', (72, 92)),         # JPEG quality of the camera's encoder
])
#: Bayer layouts (top-left 2 x 2 cell, row by row) and OpenCV's name for each
BAYER_PATTERNS = OrderedDict([('RGGB', 'BayerBG'), ('BGGR', 'BayerRG'), ('GRBG', 'BayerGB'),
                              ('GBRG', 'BayerGR')])
NOISE_SCALE = 32.0      # unit-normal noise bank stored as uint8 at this scale (8 sigma)

LookParams = namedtuple('LookParams', 'kind wb exposure_ev gamma contrast flare read_noise '
                                      'shot_noise blur_sigma vignetting jpeg_quality bayer')
LookParams.__doc__ = """One camera's look. wb: (r, g, b) channel gains (g = 1) of the cast;
exposure_ev: stops; gamma, contrast, flare: tone curve; read_noise, shot_noise: sensor noise
(linear light, full scale 1); blur_sigma: px; vignetting: share lost in the corners;
jpeg_quality: 0..100; bayer: one of BAYER_PATTERNS."""


def camera_key(camera):
    """Text naming a camera model (intrinsics): equal for both eyes of a stereo pair."""
    return '%dx%d/%.4f/%.4f/%.3f/%.3f' % (camera.width, camera.height, camera.fx, camera.fy,
                                          camera.cx, camera.cy)


def _stable_hash(text):
    return zlib.crc32(text.encode('utf-8')) & 0xffffffff


def look_params(seed, key, kind='daylight', variation=1.0):
    """Deterministic LookParams of camera `key` (see camera_key) in a scenario of `seed`.

    variation 0..1 scales every random draw toward the middle of its range (0: the mid look of
    the kind, 1: the full documented range)."""
    if kind not in KIND_RANGES:
        raise ValueError('look kind %r is not one of %s' % (kind, ', '.join(KINDS)))
    v = min(max(float(variation), 0.0), 1.0)
    rng = np.random.default_rng([int(seed), _stable_hash(key), 0x100c])
    u = rng.uniform(0.0, 1.0, 12)           # fixed draw order: one number per parameter
    pick = iter(0.5 + v * (u - 0.5))

    def draw(lo_hi):
        a = next(pick)
        return lo_hi[0] + a * (lo_hi[1] - lo_hi[0])

    kr = KIND_RANGES[kind]
    wb = (draw(kr['wb_r']), 1.0, draw(kr['wb_b']))
    ev = draw(kr['exposure_ev'])
    flare = draw(kr['flare'])
    c = dict((name, draw(rg)) for name, rg in COMMON_RANGES.items())
    bayer = list(BAYER_PATTERNS)[int(u[11] * len(BAYER_PATTERNS)) % len(BAYER_PATTERNS)]
    return LookParams(kind, tuple(round(x, 4) for x in wb), round(ev, 4),
                      round(c['gamma'], 4), round(c['contrast'], 4), round(flare, 4),
                      c['read_noise'], c['shot_noise'], round(c['blur_sigma'], 3),
                      round(c['vignetting'], 3), int(round(c['jpeg_quality'])), bayer)


def srgb_to_linear(x):
    x = np.asarray(x, dtype=np.float64)
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(y):
    y = np.clip(np.asarray(y, dtype=np.float64), 0.0, 1.0)
    return np.where(y <= 0.0031308, y * 12.92, 1.055 * y ** (1.0 / 2.4) - 0.055)


def tone(signal, params):
    """Encoded output (0..1) of linear sensor signal (after the channel gain; 1 = clipping)."""
    lin = np.clip(signal, 0.0, 1.0) ** params.gamma
    e = linear_to_srgb(lin)
    e = e - params.contrast * np.sin(2.0 * math.pi * e) / (2.0 * math.pi)
    return params.flare + (1.0 - params.flare) * e


def channel_gains(params):
    """(r, g, b) total gain of each channel: the cast (normalised to unit luminance, so that it
    changes the colour and not the brightness) times the exposure."""
    r, g, b = params.wb
    k = 2.0 ** params.exposure_ev / (0.299 * r + 0.587 * g + 0.114 * b)
    return tuple(w * k for w in params.wb)


def tone_luts(params, noise_scale=1.0):
    """Per channel (B, G, R order): uint8 tone LUT of the input value, and uint8 LUT of the
    display-domain noise sigma (DN * 256 / NOISE_SCALE) at that input value."""
    x = np.arange(256) / 255.0
    lin = srgb_to_linear(x)
    grid = np.linspace(0.0, 1.2, 4801)
    out = tone(grid, params)
    slope = np.gradient(out, grid)
    slope[grid >= 1.0] = 0.0                 # clipped: flat, no noise
    luts, sigmas = [], []
    for gain in channel_gains(params)[::-1]:
        s = lin * gain
        luts.append(np.clip(np.round(tone(s, params) * 255.0), 0, 255).astype(np.uint8))
        var = gain * params.shot_noise * s + (gain * params.read_noise) ** 2
        sig = np.interp(s, grid, slope) * np.sqrt(var) * 255.0 * noise_scale
        sigmas.append(np.clip(np.round(sig * 256.0 / NOISE_SCALE), 0, 255).astype(np.uint8))
    return luts, sigmas


def _sites(pattern):
    """[(dy, dx, channel index in BGR)] of the 2 x 2 Bayer cell."""
    index = {'B': 0, 'G': 1, 'R': 2}
    return [(k // 2, k % 2, index[ch]) for k, ch in enumerate(pattern)]


def noise_bank(seed, name, width, height, count=4):
    """`count` frames of unit-normal noise for the eye `name`: each a list over the four Bayer
    sites of (positive, negative) half-resolution uint8 arrays scaled by NOISE_SCALE."""
    rng = np.random.default_rng([int(seed), _stable_hash(name), 0x5eed])
    h2, w2 = height // 2, width // 2
    frames = []
    for _ in range(count):
        sites = []
        for _ in range(4):
            n = rng.standard_normal((h2, w2), dtype=np.float32) * np.float32(NOISE_SCALE)
            sites.append((np.clip(n, 0, 255).astype(np.uint8),
                          np.clip(-n, 0, 255).astype(np.uint8)))
        frames.append(sites)
    return frames


class CameraLook(object):
    """Applies one camera's LookParams to rendered BGR uint8 images of one size (precomputed
    LUTs, vignetting map, blur kernel; apply() costs a few ms per 1024x768 frame)."""

    def __init__(self, params, width, height, noise_scale=1.0):
        if width % 2 or height % 2:
            raise ValueError('the Bayer mosaic needs an even image size, got %dx%d'
                             % (width, height))
        self.params = params
        self.width, self.height = int(width), int(height)
        self.ksize = 0
        blur_gain = 1.0
        if params.blur_sigma > 0:
            self.ksize = 3 if params.blur_sigma < 0.7 else 5
            k1 = cv2.getGaussianKernel(self.ksize, params.blur_sigma)
            blur_gain = float(np.sqrt(np.sum(k1 ** 2))) ** 2      # noise std kept by the blur
        # the blur acts on the demosaiced luma: raise the noise so that its std in the final
        # image is the sensor's
        self.luts, self.sigma_luts = tone_luts(params, noise_scale / blur_gain)
        self.sites = _sites(params.bayer)
        self.gray_code = getattr(cv2, 'COLOR_%s2GRAY' % BAYER_PATTERNS[params.bayer])
        self.vignette = None
        if params.vignetting > 0:
            # linear falloff 1 - k (r / r_corner)^2, encoded
            yy, xx = np.mgrid[0:self.height, 0:self.width].astype(np.float64)
            r2 = ((xx - (self.width - 1) / 2.0) ** 2 + (yy - (self.height - 1) / 2.0) ** 2) / \
                (((self.width - 1) / 2.0) ** 2 + ((self.height - 1) / 2.0) ** 2)
            fall = linear_to_srgb(1.0 - params.vignetting * r2)
            self.vignette = np.clip(np.round(fall * 255.0), 0, 255).astype(np.uint8)
        self.jpeg = [int(cv2.IMWRITE_JPEG_QUALITY), int(params.jpeg_quality)]

    def apply(self, img, noise=None):
        """The camera's picture of a rendered BGR image; noise: one frame of noise_bank (None:
        no sensor noise)."""
        h, w = self.height, self.width
        if img.shape[:2] != (h, w):
            raise ValueError('look made for %dx%d, image is %dx%d'
                             % (w, h, img.shape[1], img.shape[0]))
        raw = np.empty((h, w), np.uint8)
        planes = [None, [], None]                              # B, [G, G], R at half size
        for k, (dy, dx, c) in enumerate(self.sites):
            sub = np.ascontiguousarray(img[dy::2, dx::2, c])
            out = cv2.LUT(sub, self.luts[c])
            if noise is not None:
                sig = cv2.LUT(sub, self.sigma_luts[c])
                pos, neg = noise[k]
                out = cv2.subtract(cv2.add(out, cv2.multiply(pos, sig, scale=1.0 / 256.0)),
                                   cv2.multiply(neg, sig, scale=1.0 / 256.0))
            raw[dy::2, dx::2] = out
            if c == 1:
                planes[1].append(out)
            else:
                planes[c] = out
        # colour: one sample of each channel per 2 x 2 cell (half resolution, JPEG 4:2:0)
        green = cv2.addWeighted(planes[1][0], 0.5, planes[1][1], 0.5, 0.0)
        half = cv2.cvtColor(cv2.merge([planes[0], green, planes[2]]), cv2.COLOR_BGR2YCrCb)
        ycc = cv2.resize(half, (w, h), interpolation=cv2.INTER_LINEAR)
        # luma: bilinear demosaic of the mosaic, optics blur, vignetting, JPEG
        luma = cv2.cvtColor(raw, self.gray_code)
        if self.ksize:
            luma = cv2.GaussianBlur(luma, (self.ksize, self.ksize), self.params.blur_sigma)
        if self.vignette is not None:
            luma = cv2.multiply(luma, self.vignette, scale=1.0 / 255.0)
        ok, buf = cv2.imencode('.jpg', luma, self.jpeg)
        if ok:
            luma = cv2.imdecode(buf, cv2.IMREAD_GRAYSCALE)
        cv2.insertChannel(luma, ycc, 0)
        return cv2.cvtColor(ycc, cv2.COLOR_YCrCb2BGR)


__all__ = ['KINDS', 'KIND_RANGES', 'COMMON_RANGES', 'BAYER_PATTERNS', 'LookParams',
           'CameraLook', 'camera_key', 'look_params', 'noise_bank', 'tone', 'tone_luts',
           'channel_gains', 'srgb_to_linear', 'linear_to_srgb']
