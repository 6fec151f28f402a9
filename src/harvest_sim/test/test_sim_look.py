"""Camera look (harvest_sim.look) and the realism of the renders: the look is a deterministic
function of (seed, camera model), stays inside its documented ranges, the LED kind has its
pink-magenta cast, both stereo eyes share one look with independent noise, geometry is kept,
and rendered fruit colours match the ones measured on real photographs."""

import cv2
import numpy as np
import pytest

from sim_fixtures import GEOM, SCENARIOS, scn, single_fruit_scenario

from harvest_sim import camera_model, look, render

STEREO = camera_model.stereo_camera()
HAND = camera_model.hand_camera()


def grey(level, w=64, h=48):
    img = np.empty((h, w, 3), np.uint8)
    img[:] = level
    return img


def ident(**changes):
    """A neutral look (no cast, no exposure change, linear tone, no blur/vignetting)."""
    p = look.LookParams('daylight', (1.0, 1.0, 1.0), 0.0, 1.0, 0.0, 0.0, 0.0008, 0.0003, 0.0,
                        0.0, 100, 'RGGB')
    return p._replace(**changes)


def test_look_is_deterministic_per_seed_and_camera_model():
    key = look.camera_key(STEREO)
    a = look.look_params(7, key, 'daylight')
    assert a == look.look_params(7, key, 'daylight')
    assert a != look.look_params(8, key, 'daylight')
    assert a != look.look_params(7, look.camera_key(HAND), 'daylight')
    img = (np.random.default_rng(0).uniform(0, 255, (96, 128, 3))).astype(np.uint8)
    bank = look.noise_bank(7, 'left', 128, 96)
    one = look.CameraLook(a, 128, 96).apply(img, bank[1])
    two = look.CameraLook(look.look_params(7, key, 'daylight'), 128, 96).apply(
        img, look.noise_bank(7, 'left', 128, 96)[1])
    assert np.array_equal(one, two)


@pytest.mark.parametrize('kind', look.KINDS)
def test_white_balance_and_exposure_stay_in_their_documented_ranges(kind):
    kr, cr = look.KIND_RANGES[kind], look.COMMON_RANGES
    seen_ev = []
    for seed in range(150):
        for cam in (STEREO, HAND):
            p = look.look_params(seed, look.camera_key(cam), kind)
            r, g, b = p.wb
            assert g == 1.0
            assert kr['wb_r'][0] <= r <= kr['wb_r'][1]
            assert kr['wb_b'][0] <= b <= kr['wb_b'][1]
            assert kr['exposure_ev'][0] <= p.exposure_ev <= kr['exposure_ev'][1]
            assert kr['flare'][0] <= p.flare <= kr['flare'][1]
            for name in ('gamma', 'contrast', 'blur_sigma', 'vignetting'):
                assert cr[name][0] <= getattr(p, name) <= cr[name][1], name
            assert cr['jpeg_quality'][0] <= p.jpeg_quality <= cr['jpeg_quality'][1]
            assert p.bayer in look.BAYER_PATTERNS
            seen_ev.append(p.exposure_ev)
    # the draws really spread over the range (not stuck at one value)
    lo, hi = kr['exposure_ev']
    assert min(seen_ev) < lo + 0.15 * (hi - lo) and max(seen_ev) > hi - 0.15 * (hi - lo)


def test_variation_zero_gives_the_middle_of_every_range():
    p = look.look_params(3, 'any', 'warm', variation=0.0)
    kr = look.KIND_RANGES['warm']
    assert p.wb[0] == pytest.approx(sum(kr['wb_r']) / 2, abs=1e-4)
    assert p.exposure_ev == pytest.approx(sum(kr['exposure_ev']) / 2, abs=1e-4)
    assert p == look.look_params(99, 'other', 'warm', variation=0.0)._replace(bayer=p.bayer)


def test_unknown_kind_is_refused():
    with pytest.raises(ValueError, match='not one of'):
        look.look_params(1, 'x', 'sodium')


def _ratios(out):
    b, g, r = [float(v) for v in out[8:-8, 8:-8].reshape(-1, 3).mean(axis=0)]
    return r / g, b / g


def test_led_look_has_its_pink_magenta_cast():
    for seed in range(20):
        p = look.look_params(seed, look.camera_key(STEREO), 'led')
        rg, bg = _ratios(look.CameraLook(p, 64, 48).apply(grey(128)))
        # linear gains R/G >= 1.8, B/G >= 1.6 are about 1.28 and 1.2 once display-encoded
        assert rg > 1.2 and bg > 1.15, (seed, rg, bg)


def test_daylight_look_keeps_grey_nearly_neutral_and_warm_is_orange():
    for seed in range(20):
        p = look.look_params(seed, look.camera_key(STEREO), 'daylight')
        rg, bg = _ratios(look.CameraLook(p, 64, 48).apply(grey(128)))
        assert 0.85 < rg < 1.1 and 0.95 < bg < 1.2, (seed, rg, bg)
        p = look.look_params(seed, look.camera_key(STEREO), 'warm')
        rg, bg = _ratios(look.CameraLook(p, 64, 48).apply(grey(128)))
        assert rg > 1.02 and bg < 0.95, (seed, rg, bg)


def test_exposure_brightens_and_the_cast_does_not():
    means = [look.CameraLook(ident(exposure_ev=ev), 64, 48).apply(grey(100)).mean()
             for ev in (-0.5, 0.0, 0.5)]
    assert means[0] < means[1] < means[2]
    assert means[1] == pytest.approx(100, abs=2)
    # a cast changes the colour at (nearly) constant luminance
    out = look.CameraLook(ident(wb=(1.5, 1.0, 1.3)), 64, 48).apply(grey(100))
    luma = cv2.cvtColor(out, cv2.COLOR_BGR2GRAY).mean()
    assert luma == pytest.approx(100, abs=6)


def test_neutral_look_reproduces_the_rendered_image():
    yy, xx = np.mgrid[0:48, 0:64]
    img = np.stack([xx * 3, yy * 4, 255 - xx * 2], -1).astype(np.uint8)
    out = look.CameraLook(ident(), 64, 48).apply(img)
    assert np.abs(out.astype(int) - img).mean() < 1.5


def test_noise_is_signal_dependent_and_vanishes_where_the_sensor_clips():
    p = ident(read_noise=0.001, shot_noise=0.0005)
    cam = look.CameraLook(p, 256, 192)
    bank = look.noise_bank(1, 'eye', 256, 192)

    def noise_std(level, params=None):
        c = cam if params is None else look.CameraLook(params, 256, 192)
        a = c.apply(grey(level, 256, 192), bank[0]).astype(float)
        b = c.apply(grey(level, 256, 192), bank[1]).astype(float)
        return (a - b).std() / np.sqrt(2)
    dark, mid = noise_std(25), noise_std(128)
    assert 0.5 < mid < 5.0 and 0.5 < dark < 8.0
    assert dark != pytest.approx(mid, rel=0.1)            # depends on the signal
    # 1.5 stops over: white is clipped and flat
    assert noise_std(250, p._replace(exposure_ev=1.5)) < 0.3
    lut_sig = look.tone_luts(p)[1][1]
    assert lut_sig[30] > lut_sig[200] > 0


def test_look_keeps_geometry_a_bright_square_stays_centred():
    img = grey(40, 128, 96)
    img[40:56, 50:70] = (60, 90, 230)
    out = look.CameraLook(ident(blur_sigma=0.7, vignetting=0.2, jpeg_quality=75), 128,
                          96).apply(img)
    w = np.clip(out[:, :, 2].astype(float) - 60.0, 0, None)
    ys, xs = np.mgrid[0:96, 0:128]
    cx, cy = (w * xs).sum() / w.sum(), (w * ys).sum() / w.sum()
    assert cx == pytest.approx(59.5, abs=0.3) and cy == pytest.approx(47.5, abs=0.3)


@pytest.mark.parametrize('pattern', list(look.BAYER_PATTERNS))
def test_every_bayer_pattern_demosaics_to_the_right_colour(pattern):
    img = grey(0)
    img[:] = (30, 100, 200)
    out = look.CameraLook(ident(bayer=pattern), 64, 48).apply(img)
    assert np.abs(out[10:-10, 10:-10].astype(int) - (30, 100, 200)).max() <= 3


def _eyes():
    return render.camera_poses(GEOM, {'cart_joint': 0.0})


def test_both_stereo_eyes_share_the_look_and_have_independent_noise():
    s = single_fruit_scenario((0.45, 0.06, 1.0))
    r = render.Renderer(s)
    poses = _eyes()
    fr = render.fruits_from_scenario(s)
    left = r.render(STEREO, poses['stereo_left_optical'], fr, ('left', 0))
    right = r.render(STEREO, poses['stereo_right_optical'], fr, ('right', 0))
    assert left.shape == right.shape
    assert len(r._looks) == 1                      # one look for the pair (same camera model)
    r.render(HAND, poses['hand_camera_optical'], fr, ('hand', 0))
    assert len(r._looks) == 2
    # the noise of the two eyes is uncorrelated: difference of two frames per eye
    left2 = r.render(STEREO, poses['stereo_left_optical'], fr, ('left', 1))
    right2 = r.render(STEREO, poses['stereo_right_optical'], fr, ('right', 1))
    nl = (left.astype(float) - left2.astype(float))[:, :, 1]
    nr = (right.astype(float) - right2.astype(float))[:, :, 1]
    corr = np.corrcoef(nl.ravel(), nr.ravel())[0, 1]
    assert abs(corr) < 0.05 and nl.std() > 0.5


def test_scenario_look_kind_reaches_the_renderer():
    s = scn.load_scenario(scn.resolve_scenario('plant_factory_led', SCENARIOS))
    assert s.look.kind == 'led' and s.look.background == 'film'
    r = render.Renderer(s)
    assert r.camera_look(STEREO).params.kind == 'led'
    assert render.Renderer(s, look=False).render(
        STEREO, _eyes()['stereo_left_optical'], []).shape == (768, 1024, 3)


def test_old_scenarios_without_a_look_field_get_the_default_look():
    s = single_fruit_scenario((0.45, 0.06, 1.0))
    assert s.look.kind == 'daylight' and s.look.background == 'mixed'
    assert render.Renderer(s).camera_look(STEREO).params.kind == 'daylight'


#: per stage, the range of the per-fruit median red chromaticity R/(R+G+B) and OpenCV hue
#: measured on the real development photographs (tools/measure_fruit_colours.py, README)
MEASURED = {'green': ((0.31, 0.46), (30, 49)), 'turning': ((0.38, 0.47), (20, 32)),
            'pink': ((0.47, 0.56), (8, 20)), 'red': ((0.50, 0.77), (3, 16))}


def test_rendered_fruit_colours_fall_in_the_ranges_measured_on_real_photos():
    cam = STEREO
    found = {}
    for name in ('three_targets', 'greenhouse_daylight', 'unripe_only'):    # daylight looks
        s = scn.load_scenario(scn.resolve_scenario(name, SCENARIOS))
        r = render.Renderer(s)
        fr = render.fruits_from_scenario(s)
        for i, y in enumerate(s.track.picking_points):
            T = render.camera_poses(GEOM, {'cart_joint': y})['stereo_left_optical']
            img, labels = r.render(cam, T, fr, ('left', i), labels=True)
            for k, f in enumerate(s.fruits):
                m = labels == k + 1
                if m.sum() < 300:
                    continue
                rgb = img[m][:, ::-1].astype(float)
                rgb = rgb[rgb.min(axis=1) <= 165]                  # no highlights
                chroma = float(np.median(rgb[:, 0] / np.maximum(rgb.sum(axis=1), 1.0)))
                med = np.clip(np.median(rgb, axis=0), 0, 255).astype(np.uint8)
                hue = int(cv2.cvtColor(med.reshape(1, 1, 3), cv2.COLOR_RGB2HSV)[0, 0, 0])
                found.setdefault(f.stage, []).append((chroma, hue))
    assert set(found) == set(MEASURED)
    for stage, values in found.items():
        (c0, c1), (h0, h1) = MEASURED[stage]
        chroma = np.mean([c for c, _ in values])
        hue = np.mean([h for _, h in values])
        assert c0 <= chroma <= c1, (stage, chroma)
        assert h0 <= hue <= h1, (stage, hue)
    red = [c for c, _ in found['red']]
    assert 0.59 <= np.mean(red) <= 0.68          # real red fruit, not the old 0.84
