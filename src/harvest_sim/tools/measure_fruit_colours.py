#!/usr/bin/env python3
"""Measure tomato skin colours per ripeness stage on real photographs (development tool).

    python measure_fruit_colours.py [--photos DIR] [--labels real_photo_labels.yaml]
                                     [--overlay OUT_DIR]

For every hand-labelled fruit circle (real_photo_labels.yaml) it takes the pixels inside
0.8 r and splits them into
  - highlight: bright and whitish (min(R, G, B) > 165): the specular reflection;
  - sepal/stem: green pixels on a fruit that is not green (OpenCV hue 25..95, S > 0.25);
  - skin: the rest;
and prints per fruit and per stage: the median skin colour (sRGB 0..255), its red
chromaticity R/(R+G+B), OpenCV HSV (H 0..180), the spread of brightness (V at the 10th and
90th percentile: shading), the shoulder (top 30 % of the disc) and bottom (lowest 30 %)
colours, and the share of highlight pixels. The numbers feed RIPENESS_COLOURS in
harvest_sim/render.py (README: Measured fruit colours).

The photographs are CC BY-NC-SA and stay outside the repository; --overlay writes PNG
checks of the labels to a directory of your choice (for instance /tmp), never into the repo.
"""

import argparse
import os

import cv2
import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_PHOTOS = '/work/shared/data/real-tomato-photos'
STAGE_ORDER = ('green', 'turning', 'pink', 'red')


def fruit_pixels(img, u, v, r, stage):
    """(skin, highlight share, shoulder skin, bottom skin) as N x 3 RGB arrays of one fruit."""
    h, w = img.shape[:2]
    yy, xx = np.mgrid[0:h, 0:w]
    d2 = (xx - u) ** 2 + (yy - v) ** 2
    disc = d2 <= (0.8 * r) ** 2
    rgb = img[disc][:, ::-1].astype(np.float64)
    dy = (yy[disc] - v) / float(r)
    hsv = cv2.cvtColor(img[disc].reshape(-1, 1, 3), cv2.COLOR_BGR2HSV).reshape(-1, 3)
    highlight = rgb.min(axis=1) > 165
    sepal = np.zeros(highlight.shape, bool)
    if stage in ('pink', 'red'):
        sepal = (hsv[:, 0] >= 25) & (hsv[:, 0] <= 95) & (hsv[:, 1] > 64)
    skin = ~highlight & ~sepal
    return (rgb[skin], highlight.mean(), rgb[skin & (dy < -0.24)], rgb[skin & (dy > 0.24)])


def describe(rgb):
    """Median colour and its chromaticity and HSV of N x 3 RGB pixels."""
    if len(rgb) == 0:
        return None
    med = np.median(rgb, axis=0)
    chroma = rgb[:, 0] / np.maximum(rgb.sum(axis=1), 1.0)
    px = np.clip(np.round(med), 0, 255).astype(np.uint8).reshape(1, 1, 3)
    hsv = cv2.cvtColor(px, cv2.COLOR_RGB2HSV)[0, 0]
    v = rgb.max(axis=1)
    return dict(rgb=med, r_chroma=float(np.median(chroma)), hsv=hsv,
                v10=float(np.percentile(v, 10)), v90=float(np.percentile(v, 90)))


def measure(photos, labels):
    rows = []
    for name in sorted(labels):
        img = cv2.imread(os.path.join(photos, name))
        if img is None:
            raise SystemExit('cannot read %s' % os.path.join(photos, name))
        for i, f in enumerate(labels[name]):
            skin, hl, top, bottom = fruit_pixels(img, f['u'], f['v'], f['r'], f['stage'])
            rows.append(dict(photo=name, index=i, stage=f['stage'], r=f['r'],
                             skin=describe(skin), top=describe(top), bottom=describe(bottom),
                             highlight=float(hl)))
    return rows


def _fmt(d):
    if d is None:
        return '-'
    return 'RGB %3d %3d %3d  r %.3f  H %3d S %.2f V %.2f' % (
        d['rgb'][0], d['rgb'][1], d['rgb'][2], d['r_chroma'], d['hsv'][0], d['hsv'][1] / 255.0,
        d['hsv'][2] / 255.0)


def report(rows):
    print('per fruit (skin median; shoulder; bottom; highlight share of the disc):')
    for row in rows:
        print('%-24s %2d %-7s %s | top %s | bottom %s | hl %.3f' % (
            row['photo'], row['index'], row['stage'], _fmt(row['skin']),
            _fmt(row['top'])[:15], _fmt(row['bottom'])[:15], row['highlight']))
    print('\nper stage (mean +- std over fruit of the per-fruit medians):')
    for stage in STAGE_ORDER:
        sel = [row for row in rows if row['stage'] == stage and row['skin'] is not None]
        if not sel:
            continue
        rgb = np.array([row['skin']['rgb'] for row in sel])
        chroma = np.array([row['skin']['r_chroma'] for row in sel])
        hue = np.array([float(row['skin']['hsv'][0]) for row in sel])
        sat = np.array([row['skin']['hsv'][1] / 255.0 for row in sel])
        val = np.array([row['skin']['hsv'][2] / 255.0 for row in sel])
        v10 = np.array([row['skin']['v10'] for row in sel])
        v90 = np.array([row['skin']['v90'] for row in sel])
        hl = np.array([row['highlight'] for row in sel])
        tops = np.array([row['top']['rgb'] for row in sel if row['top'] is not None])
        bots = np.array([row['bottom']['rgb'] for row in sel if row['bottom'] is not None])
        print('%-7s n=%2d  RGB %s +- %s  r %.3f +- %.3f (%.3f..%.3f)  H %.1f +- %.1f  '
              'S %.2f +- %.2f  V %.2f +- %.2f  V10/V90 %.0f/%.0f  highlight %.3f (max %.3f)'
              % (stage, len(sel), np.round(rgb.mean(0)).astype(int),
                 np.round(rgb.std(0)).astype(int), chroma.mean(), chroma.std(), chroma.min(),
                 chroma.max(), hue.mean(), hue.std(), sat.mean(), sat.std(), val.mean(),
                 val.std(), v10.mean(), v90.mean(), hl.mean(), hl.max()))
        print('        shoulder RGB %s   bottom RGB %s'
              % (np.round(tops.mean(0)).astype(int), np.round(bots.mean(0)).astype(int)))


def overlay(photos, labels, out_dir):
    colours = {'green': (0, 255, 0), 'turning': (0, 255, 255), 'pink': (255, 0, 255),
               'red': (0, 0, 255)}
    for name in sorted(labels):
        img = cv2.imread(os.path.join(photos, name))
        for i, f in enumerate(labels[name]):
            cv2.circle(img, (f['u'], f['v']), f['r'], (255, 255, 255), 2)
            cv2.circle(img, (f['u'], f['v']), int(0.8 * f['r']), colours[f['stage']], 1)
            cv2.putText(img, str(i), (f['u'] - 8, f['v'] + 6), cv2.FONT_HERSHEY_SIMPLEX, 0.7,
                        colours[f['stage']], 2)
        cv2.imwrite(os.path.join(out_dir, os.path.splitext(name)[0] + '_labels.png'), img)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--photos', default=DEFAULT_PHOTOS)
    ap.add_argument('--labels', default=os.path.join(HERE, 'real_photo_labels.yaml'))
    ap.add_argument('--overlay', help='write label check PNGs to this directory (not the repo)')
    a = ap.parse_args(argv)
    with open(a.labels) as f:
        labels = yaml.load(f, Loader=yaml.SafeLoader)
    if a.overlay:
        overlay(a.photos, labels, a.overlay)
    report(measure(a.photos, labels))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
