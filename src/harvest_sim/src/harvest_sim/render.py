"""Ray-cast renderer of the simulated greenhouse (numpy + OpenCV, no rospy).

Geometry is exact pinhole geometry: every pixel (u, v) is the ray through its centre, and
fruit (spheres), leaves (planar leaflets) and stems (capsules) are intersected with those rays
inside their projected bounding boxes; a depth buffer resolves occlusion. The background is the
canopy behind the row (plane x = track.backdrop_x), the opposite row (x = track.aisle_x), the
floor (z = 0) and the roof (z = ROOF_Z): textured planes ray-cast at half resolution into one
texture atlas and scaled up. Every surface carries texture fixed in 3-D, so block matching
finds the same pattern in both eyes.

Shading: Lambert + ambient with the scenario's light (intensity, colour, direction); fruit
skin is glossy (a sharp highlight of the light, a broad sheen, a soft highlight of the bright
sky/film above and Fresnel brightening at grazing angles), carries a fine surface texture and
ripens unevenly: from the blossom end up and in blotches (turning and pink fruit are mottled,
with green shoulders; mature green fruit have pale shoulders). Every fruit wears a calyx: a
star of thin green sepals (3-D capsules lying on the shoulders, tips lifting off) round the
pedicel. The background planes show the scenario's look.background (dense foliage, foliage
with plastic film and greenhouse equipment between the plants, or film with sparse plants).

Every frame then goes through the camera look of harvest_sim/look.py (white balance, exposure,
tone curve, blur, vignetting, Bayer mosaic with signal-dependent noise, demosaicing, JPEG),
drawn per (scenario seed, camera model) and the scenario's look.kind; the noise comes from a
bank per camera name (eye) seeded by the scenario seed, so a frame is a deterministic function
of (seed, camera name, frame index, scene).

Colour of a fruit by ripeness (display sRGB 0..1, interpolated; see RIPENESS_COLOURS), measured
on real photographs (tools/measure_fruit_colours.py, README): mature green (0-0.2) ->
turning yellow-orange (0.35) -> pink-orange (0.55) -> orange-red (0.7) -> red (1.0).
"""

import math
from collections import namedtuple

import cv2
import numpy as np

from harvest_sim import camera_model, look as camera_look
from harvest_sim.render_background import BackgroundPainter, Plane
from harvest_sim.render_objects import ObjectPainter
from harvest_sim.render_materials import (BOUNCE, LABEL_LEAF, LABEL_STEM, ROOF_Z, STATIC_CACHE,
                                          STEM_RGB, fruit_albedo, noise_texture, rgb_to_bgr,
                                          skin_texture)

RenderFruit = namedtuple('RenderFruit', 'index position radius ripeness pedicel_top attached '
                                        'cut_point moving', defaults=(False,))
RenderFruit.__doc__ = """A fruit as the renderer needs it (map frame).

index: stable integer (texture and label, label = index + 1); attached: still on its pedicel
(hanging or held); cut_point: where its pedicel was cut (None if attached); moving: held by the
suction sleeve (drawn per frame; the other fruit are cached with the static scene)."""


def fruits_from_scenario(scenario):
    """RenderFruit list of a scenario's fruit, all hanging at their scenario positions."""
    return [RenderFruit(i, f.position, f.radius, f.ripeness, f.pedicel_top, True, None)
            for i, f in enumerate(scenario.fruits)]


class Renderer(BackgroundPainter, ObjectPainter):
    """Renders a scenario from any camera pose; static scene, dynamic fruit passed per call."""

    def __init__(self, scenario, seed=None, noise_sigma=2.0, blur_sigma=None, look=True):
        """noise_sigma scales the look's sensor noise (2.0 = as documented, 0 = none);
        blur_sigma (px) overrides the look's optics blur; look=False renders the clean image
        (no camera look at all)."""
        self.scenario = scenario
        self.seed = int(scenario.seed if seed is None else seed)
        self.noise_sigma = float(noise_sigma)
        self.blur_sigma = blur_sigma
        self.use_look = bool(look)
        self.look_config = getattr(scenario, 'look', None)
        self._looks = {}
        lt = scenario.lighting
        self.light_dir = np.asarray(lt.direction, dtype=float)
        self.light_bgr = rgb_to_bgr(lt.colour) * np.float32(lt.intensity)
        # ambient = share of diffuse sky light: it dims with the intensity too
        self.ambient_bgr = rgb_to_bgr(lt.colour) * np.float32(lt.ambient * lt.intensity)
        self.bounce_bgr = rgb_to_bgr(lt.colour) * np.float32(BOUNCE * lt.intensity)
        # what the glossy skin mirrors from above (sky through the film, lamps)
        self.sky_bgr = rgb_to_bgr(lt.colour) * np.float32(0.3 + 0.7 * lt.intensity)
        rng = np.random.default_rng(self.seed)
        self.fruit_tex = skin_texture(rng, (128, 256))
        self.leaf_tex = noise_texture(rng, (128, 128), 1.0)
        self.fruit_phase = rng.uniform(0.0, 1.0, 4096)
        self.blotch_tex = noise_texture(rng, (32, 64), 1.5)
        canopy_lit = np.float32((lt.ambient + 0.45) * lt.intensity)
        self._build_atlas(rng, canopy_lit,
                          np.float32((lt.ambient + 0.6) * lt.intensity),
                          np.float32(0.3 + 0.8 * lt.intensity))
        self.planes = [Plane(0, scenario.track.backdrop_x, 'canopy', *self._atlas_slots[0]),
                       Plane(0, scenario.track.aisle_x, 'canopy', *self._atlas_slots[1]),
                       Plane(2, 0.0, 'floor', *self._atlas_slots[2]),
                       Plane(2, ROOF_Z, 'roof', *self._atlas_slots[3])]
        self.stems = [(s.points, s.radius) for s in scenario.stems]
        self._noise = {}
        self._rays = {}
        self._static = {}          # camera pose -> (image, depth, labels) without the fruit

    # ------------------------------------------------------------------ helpers
    def _ray_grid(self, camera):
        key = (camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy)
        if key not in self._rays:
            xs, ys = camera.ray_grid()
            self._rays[key] = (xs.astype(np.float32), ys.astype(np.float32))
        return self._rays[key]

    def noise_frames(self, name, width, height, count=4):
        """Bank of `count` sensor noise frames of the camera (eye) `name` (look.noise_bank)."""
        key = (name, width, height)
        if key not in self._noise:
            self._noise[key] = camera_look.noise_bank(self.seed, name, width, height, count)
        return self._noise[key]

    def camera_look(self, camera):
        """The CameraLook of a camera model (shared by both eyes of a stereo pair)."""
        w, h = camera.width + camera.width % 2, camera.height + camera.height % 2
        key = (camera_look.camera_key(camera), w, h)
        if key not in self._looks:
            cfg = self.look_config
            params = camera_look.look_params(self.seed, key[0],
                                             cfg.kind if cfg is not None else 'daylight',
                                             cfg.variation if cfg is not None else 1.0)
            if self.blur_sigma is not None:
                params = params._replace(blur_sigma=float(self.blur_sigma))
            self._looks[key] = camera_look.CameraLook(params, w, h, self.noise_sigma / 2.0)
        return self._looks[key]

    def _apply_look(self, img, camera, noise_key):
        look = self.camera_look(camera)
        h, w = img.shape[:2]
        if (w, h) != (look.width, look.height):        # odd size: pad for the Bayer mosaic
            img = cv2.copyMakeBorder(img, 0, look.height - h, 0, look.width - w,
                                     cv2.BORDER_REPLICATE)
        noise = None
        if noise_key is not None and self.noise_sigma > 0:
            bank = self.noise_frames(noise_key[0], look.width, look.height)
            noise = bank[int(noise_key[1]) % len(bank)]
        out = look.apply(img, noise)
        return out if out.shape[:2] == (h, w) else np.ascontiguousarray(out[:h, :w])

    # ------------------------------------------------------------------ main entry
    def render(self, camera, T_map_cam, fruits, noise_key=None, labels=False):
        """BGR uint8 image (and an int16 label image if labels) seen by `camera` at T_map_cam.

        fruits: RenderFruit list (map frame); noise_key: (camera name, frame index) selects the
        deterministic noise frame, None renders without noise.
        """
        T = np.asarray(T_map_cam, dtype=float)
        ctx = _Frame(self, camera, T, labels)
        still = [f for f in fruits if not f.moving]
        key = (camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy,
               T.tobytes(), labels,
               tuple((f.index, tuple(np.round(f.position, 5)), f.attached,
                      None if f.cut_point is None else tuple(np.round(f.cut_point, 5)))
                     for f in still))
        layer = self._static.get(key)
        if layer is None:
            # everything but the moving (held) fruit depends on the camera pose and the still
            # fruit only: keep that layer (image, depth, labels) and draw the moving fruit on a
            # copy of it
            self._background(ctx)
            for points, radius in self.stems:
                for a, b in zip(points[:-1], points[1:]):
                    self._capsule(ctx, a, b, radius, STEM_RGB, LABEL_STEM)
            for i, leaf in enumerate(self.scenario.leaves):
                self._leaf(ctx, leaf, LABEL_LEAF + i)
            self._fruits(ctx, still)
            layer = (ctx.img.copy(), ctx.zbuf.copy(),
                     None if ctx.labels is None else ctx.labels.copy())
            if len(self._static) >= STATIC_CACHE:
                self._static.pop(next(iter(self._static)))
            self._static[key] = layer
        else:
            ctx.img[:], ctx.zbuf[:] = layer[0], layer[1]
            if labels:
                ctx.labels[:] = layer[2]
        self._fruits(ctx, [f for f in fruits if f.moving])
        img = ctx.img
        if self.use_look:
            img = self._apply_look(img, camera, noise_key)
        if labels:
            return img, ctx.labels
        return img


class _Frame(object):
    """Per-render state: camera, pose, image, depth buffer, labels."""

    def __init__(self, renderer, camera, T, labels):
        self.camera = camera
        self.R, self.t = T[:3, :3], T[:3, 3]
        self.xs, self.ys = renderer._ray_grid(camera)
        self.img = np.empty((camera.height, camera.width, 3), np.uint8)
        self.zbuf = np.full((camera.height, camera.width), np.inf, np.float32)
        self.labels = np.zeros((camera.height, camera.width), np.int16) if labels else None
        self.light_cam = self.R.T.dot(renderer.light_dir).astype(np.float32)

    def to_cam(self, p):
        return self.R.T.dot(np.asarray(p, dtype=float) - self.t)

    def full_box(self):
        return 0, self.camera.width, 0, self.camera.height

    def clip_box(self, u0, u1, v0, v1):
        u0, v0 = max(u0, 0), max(v0, 0)
        u1, v1 = min(u1, self.camera.width), min(v1, self.camera.height)
        if u0 >= u1 or v0 >= v1:
            return None
        return u0, u1, v0, v1

    def bbox_of_points(self, pts):
        uv = self.camera.project(pts)
        return self.clip_box(int(math.floor(uv[:, 0].min())) - 1,
                             int(math.ceil(uv[:, 0].max())) + 2,
                             int(math.floor(uv[:, 1].min())) - 1,
                             int(math.ceil(uv[:, 1].max())) + 2)

    def put(self, rows, cols, z, bgr, label):
        self.zbuf[rows, cols] = z
        v = bgr * np.float32(255.0)
        np.clip(v, 0.0, 255.0, out=v)
        self.img[rows, cols] = v.astype(np.uint8)
        if self.labels is not None:
            self.labels[rows, cols] = label


def camera_poses(geom, joints):
    """Poses in map of the three cameras for a joint dict (URDF names)."""
    poses = geom.frame_transforms(joints)
    return {k: poses[k] for k in ('stereo_left_optical', 'stereo_right_optical',
                                  'hand_camera_optical')}


__all__ = ['Renderer', 'RenderFruit', 'fruit_albedo', 'fruits_from_scenario', 'camera_poses',
           'camera_model']
