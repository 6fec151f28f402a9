"""Fruit, leaves and stems of harvest_sim's renderer (mixin of render.Renderer; numpy + OpenCV,
no rospy)."""

import math

import cv2
import numpy as np

from harvest_sim.render_materials import (CALYX_COS, CALYX_RGB, CUBE, FRESNEL, LABEL_STEM, LEAF_S,
                                          LEAF_W, NEAR, PALE_SHOULDER_RGB, PEDICEL_KNEE,
                                          PEDICEL_RADIUS, RIBS, SEPAL_RADIUS, SEPAL_RGB, SHEEN,
                                          SKIN_TEXEL, SKIN_TEXTURE, SKY_GLOSS, SPECULAR, STEM_RGB,
                                          WRAP, albedo_bgr, fruit_albedo, leaf_profile,
                                          mottle_weight, rgb_to_bgr, sepal_count)


class ObjectPainter(object):
    """Renderer methods: fruit (glossy spheres with calyx and sepals), leaves and stems, ray-cast
    inside their projected boxes into the frame's depth buffer."""

    def _fruits(self, ctx, fruits):
        for f in fruits:
            self._sphere(ctx, f)
        for f in fruits:
            self._sepals(ctx, f)
            top = np.asarray(f.position) + np.array([0.0, 0.0, 0.8 * f.radius])
            if f.attached:
                # the pedicel rises from the calyx to its knuckle, then bends to the truss
                knee = np.asarray(f.position) + np.array([0.0, 0.0, f.radius + PEDICEL_KNEE])
                if f.pedicel_top[2] > knee[2] + 0.005:
                    self._capsule(ctx, top, knee, PEDICEL_RADIUS, STEM_RGB, LABEL_STEM)
                    top = knee
                self._capsule(ctx, top, f.pedicel_top, PEDICEL_RADIUS, STEM_RGB, LABEL_STEM)
            else:
                stub = np.asarray(f.position) + np.array([0.0, 0.0, f.radius + 0.006])
                self._capsule(ctx, top, stub, PEDICEL_RADIUS, STEM_RGB, LABEL_STEM)
                if f.cut_point is not None:
                    self._capsule(ctx, f.cut_point, f.pedicel_top, PEDICEL_RADIUS, STEM_RGB,
                                  LABEL_STEM)

    def _sepals(self, ctx, f):
        """The calyx's star of thin sepals: each follows the shoulder from the pedicel, then
        its tip stands off the fruit (out, a little up or down). Each sepal is a polyline of
        short tapered segments rasterised as thick lines, each with the depth of its nearer
        end, front to back; sepal pixels over the fruit keep the fruit's label (the calyx is
        part of the fruit), the others are labelled as stem."""
        c = np.asarray(f.position, dtype=float)
        r = float(f.radius)
        n = sepal_count(f.index)
        phases = self.fruit_phase
        phase = phases[int(f.index) % len(phases)]
        length = 0.012 + 0.45 * r                       # cherry ~1.4 r, large fruit ~0.7 r
        th0, th1 = 0.1, 0.1 + 0.45 * length / r
        jitter = phases[(int(f.index) * 7 + np.arange(n) + 11) % len(phases)]
        phi = 2.0 * np.pi * (np.arange(n) / float(n) - phase) + 0.3 * (jitter - 0.5)
        th = np.linspace(th0, th1, 5)
        cp, sp = np.cos(phi)[:, None], np.sin(phi)[:, None]
        arc = c + (r + 0.0012) * np.stack([np.sin(th) * cp, np.sin(th) * sp,
                                           np.cos(th) + 0.0 * cp], axis=2)      # n x 5 x 3
        out = np.stack([np.cos(phi), np.sin(phi), 0.9 * (jitter - 0.45)], axis=1)
        out *= ((0.5 + 0.2 * jitter) * length / np.linalg.norm(out, axis=1))[:, None]
        line = np.concatenate([arc, arc[:, -1:] + 0.5 * out[:, None], arc[:, -1:] +
                               out[:, None]], axis=1)                             # n x 7 x 3
        m = line.shape[1] - 1
        pts = np.stack([line[:, :-1], line[:, 1:]], axis=2).reshape(-1, 3)      # segment ends
        radii = np.tile(SEPAL_RADIUS[0] + (SEPAL_RADIUS[1] - SEPAL_RADIUS[0]) *
                        np.arange(m) / float(m - 1), n)
        # lit like the fruit surface under it: normal ~ the radial direction
        nrm = line[:, :-1] - c
        nrm = (nrm / np.linalg.norm(nrm, axis=2)[:, :, None]).reshape(-1, 3)
        lam = np.maximum(ctx.R.T.dot(nrm.T).T.dot(-ctx.light_cam), 0.0)
        shade = np.repeat(0.85 + 0.3 * jitter, m)
        P = ctx.R.T.dot((pts - ctx.t).T).T                               # camera frame
        if P[:, 2].min() <= NEAR + SEPAL_RADIUS[0]:
            return
        uv = ctx.camera.project(P)
        z = P[:, 2].reshape(-1, 2)
        rad_px = ctx.camera.fx * np.array(radii) / z.min(axis=1)
        pad = int(math.ceil(rad_px.max())) + 2
        box = ctx.clip_box(int(math.floor(uv[:, 0].min())) - pad,
                           int(math.ceil(uv[:, 0].max())) + pad + 1,
                           int(math.floor(uv[:, 1].min())) - pad,
                           int(math.ceil(uv[:, 1].max())) + pad + 1)
        if box is None:
            return
        u0, u1, v0, v1 = box
        patch = np.zeros((v1 - v0, u1 - u0), np.int16)
        depth = z.min(axis=1) - np.array(radii)
        ends = np.round((uv - [u0, v0]) * 16).astype(np.int64).reshape(-1, 2, 2)
        for k in np.argsort(-depth):                      # far first: nearer ones overwrite
            a, b = ends[k]
            cv2.line(patch, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), int(k) + 1,
                     max(1, int(round(2.0 * rad_px[k]))), cv2.LINE_8, 4)
        iy, ix = np.nonzero(patch)
        if iy.size == 0:
            return
        seg = patch[iy, ix] - 1
        zz = depth[seg].astype(np.float32)
        ok = zz < ctx.zbuf[v0 + iy, u0 + ix]
        iy, ix, seg, zz = iy[ok], ix[ok], seg[ok], zz[ok]
        if iy.size == 0:
            return
        lit = (shade[:, None] * (self.ambient_bgr[None, :] + self.light_bgr[None, :] *
                                 lam[:, None])).astype(np.float32)
        out = rgb_to_bgr(SEPAL_RGB)[None, :] * lit[seg]
        label = LABEL_STEM
        if ctx.labels is not None:
            fl = int(f.index) + 1
            label = np.where(ctx.labels[v0 + iy, u0 + ix] == fl, fl, LABEL_STEM).astype(np.int16)
        ctx.put(v0 + iy, u0 + ix, zz, out, label)

    def _sphere(self, ctx, f):
        C = ctx.to_cam(f.position)
        r = float(f.radius)
        if C[2] + r <= NEAR:
            return
        box = ctx.bbox_of_points(C + r * CUBE) if C[2] - r > NEAR else ctx.full_box()
        if box is None:
            return
        u0, u1, v0, v1 = box
        X = ctx.xs[u0:u1][None, :]
        Y = ctx.ys[v0:v1][:, None]
        dC = X * np.float32(C[0]) + Y * np.float32(C[1]) + np.float32(C[2])
        dd = X * X + Y * Y + np.float32(1.0)
        disc = dC * dC - dd * np.float32(C.dot(C) - r * r)
        hit = disc > 0
        if not hit.any():
            return
        z = np.where(hit, (dC - np.sqrt(np.maximum(disc, 0))) / dd, np.inf)
        zb = ctx.zbuf[v0:v1, u0:u1]
        hit &= (z > NEAR) & (z < zb)
        iy, ix = np.nonzero(hit)
        if iy.size == 0:
            return
        zz = z[iy, ix]
        rx, ry = ctx.xs[u0 + ix], ctx.ys[v0 + iy]          # ray (rx, ry, 1) of each pixel
        C32 = C.astype(np.float32)
        ir = np.float32(1.0 / r)
        n = np.stack([(rx * zz - C32[0]) * ir, (ry * zz - C32[1]) * ir, (zz - C32[2]) * ir],
                     axis=1)
        # fruit-fixed frame (the fruit hangs upright): up, and two horizontal axes
        up = ctx.R[2].astype(np.float32)                 # map z in camera coordinates
        e1 = ctx.R[0].astype(np.float32)                 # map x in camera coordinates
        e2 = np.cross(up, e1)
        cos_t = n.dot(up)
        a1, a2 = n.dot(e1), n.dot(e2)
        # fine surface texture, tri-planar: three projections of one noise texture weighted by
        # the squared normal components (which sum to 1); shifted per fruit
        th_n, tw_n = self.fruit_tex.shape
        phase = self.fruit_phase[int(f.index) % len(self.fruit_phase)]
        k = np.float32(min((th_n - 1) * 0.5, float(f.radius) / SKIN_TEXEL))
        off = int(phase * tw_n)
        npx = a1.shape[0]
        rows = -(-npx // 512)                # remap wants 2-D maps below 32767 a side
        f1, f2, f3 = [np.resize(((v + 1.0) * k).astype(np.float32), rows * 512).reshape(rows, 512)
                      for v in (a1, a2, cos_t)]
        T = self.fruit_tex

        def sample(col, row):               # bilinear, wrapping round the texture
            return cv2.remap(T, col, row, cv2.INTER_LINEAR,
                             borderMode=cv2.BORDER_WRAP).reshape(-1)[:npx]
        tex = (a1 * a1 * sample(f3 + off, f2) + a2 * a2 * sample(f3 + (off + th_n), f1) +
               cos_t * cos_t * sample(f2 + (off + 2 * th_n), f1))
        rip = min(max(float(f.ripeness), 0.0), 1.0)
        mottle = mottle_weight(rip)
        if mottle > 0:
            # uneven ripening: riper toward the blossom end (bottom), in blotches
            B = self.blotch_tex
            bh, bw = B.shape
            kb = np.float32((bh - 1) * 0.5)
            j1, j2, j3 = ((a1 + 1.0) * kb).astype(np.int32), ((a2 + 1.0) * kb).astype(np.int32), \
                ((cos_t + 1.0) * kb).astype(np.int32)
            ob = int(phase * bw)
            blotch = (a1 * a1 * B[j2, (j3 + ob) % bw] + a2 * a2 * B[j1, (j3 + ob + bh) % bw] +
                      cos_t * cos_t * B[j1, (j2 + ob + 2 * bh) % bw])
            local = rip + np.float32(mottle) * (np.float32(-0.16) * cos_t +
                                                np.float32(0.05) * blotch)
            out = albedo_bgr(local)
        else:
            out = np.repeat(rgb_to_bgr(fruit_albedo(rip))[None, :], cos_t.shape[0], axis=0)
        if rip < 0.3:
            # mature green fruit: pale, yellowish shoulders
            pale = (np.float32(0.55 * (0.3 - rip) / 0.3) * np.maximum(cos_t, 0.0) ** 2)[:, None]
            out = out * (1 - pale) + rgb_to_bgr(PALE_SHOULDER_RGB)[None, :] * pale
        out *= (1.0 + np.float32(SKIN_TEXTURE) * tex)[:, None]
        # calyx base: a small star round the top (the sepals themselves are 3-D, see _sepals)
        n_sep = sepal_count(f.index)
        cap = np.nonzero(cos_t > CALYX_COS)[0]
        calyx = np.zeros(cos_t.shape, bool)
        if cap.size:
            theta = np.arccos(np.minimum(cos_t[cap], 1.0))
            phi = np.arctan2(a2[cap], a1[cap]) + np.float32(phase * 2 * math.pi)
            arm = np.abs(np.cos(0.5 * n_sep * phi)) ** 6
            calyx[cap] = theta < (0.13 + 0.30 * arm) * (0.8 + 0.2 * (1.0 - rip))
            out[calyx] = rgb_to_bgr(CALYX_RGB) * (1.0 + 0.15 * tex[calyx, None])
        rib = min(max((float(f.radius) - RIBS[0]) / (RIBS[1] - RIBS[0]), 0.0), 1.0) * RIBS[2]
        if rib > 0:
            # large fruit are lobed round the stem: tilt the shading normal across the lobes
            # (the silhouette stays the sphere's)
            az = np.arctan2(a2, a1) + np.float32(phase * 2 * math.pi)
            w = (np.float32(rib) * np.sin(RIBS[3] * az) *
                 np.clip(cos_t + 0.3, 0.0, 1.0))[:, None]
            n = n + w * (np.cos(az)[:, None] * e2[None, :] - np.sin(az)[:, None] * e1[None, :])
            n /= np.linalg.norm(n, axis=1)[:, None]
        # Lambert + gloss: n.h = (n.v + n.l) / |v + l|, v = -ray / |ray|
        l = -ctx.light_cam
        nl = n.dot(l)
        inv_len = 1.0 / np.sqrt(rx * rx + ry * ry + 1.0)
        nv = -(n[:, 0] * rx + n[:, 1] * ry + n[:, 2]) * inv_len
        vl = -(rx * l[0] + ry * l[1] + l[2]) * inv_len
        nh = (nv + nl) / np.sqrt(np.maximum(2.0 + 2.0 * vl, 1e-6))
        # diffuse: the light (a large, soft source: wrapped Lambert), the ambient, and light
        # bounced up from the white floor sheet
        wrap = np.maximum((nl + np.float32(WRAP)) / np.float32(1.0 + WRAP), 0.0)
        out *= (self.ambient_bgr + self.light_bgr * wrap[:, None] +
                self.bounce_bgr * np.maximum(-cos_t, 0.0)[:, None])
        skin = np.nonzero(~calyx)[0]
        if skin.size:
            # sharp highlight and broad sheen of the light
            h = np.maximum(nh[skin], 0.0)
            spec = np.float32(SHEEN[0]) * h ** np.float32(SHEEN[1])
            sharp = h > 0.95
            spec[sharp] += np.float32(SPECULAR[0]) * h[sharp] ** np.float32(SPECULAR[1])
            # soft highlight of the bright sky/film above, and Fresnel rim (grazing angles)
            vu = -(rx[skin] * up[0] + ry[skin] * up[1] + up[2]) * inv_len[skin]
            hs = np.maximum((nv[skin] + cos_t[skin]) /
                            np.sqrt(np.maximum(2.0 + 2.0 * vu, 1e-6)), 0.0)
            sky = np.float32(SKY_GLOSS[0]) * hs ** np.float32(SKY_GLOSS[1])
            rim = np.float32(FRESNEL) * (1.0 - np.clip(nv[skin], 0.0, 1.0)) ** 5 * \
                (0.5 + 0.5 * cos_t[skin])
            out[skin] += spec[:, None] * self.light_bgr[None, :] + \
                (sky + rim)[:, None] * self.sky_bgr[None, :]
        ctx.put(v0 + iy, u0 + ix, zz, out, int(f.index) + 1)

    def _leaf(self, ctx, leaf, label):
        Lc = ctx.to_cam(leaf.centre)
        N = ctx.R.T.dot(leaf.normal)
        A = ctx.R.T.dot(leaf.axis)
        B = np.cross(N, A)
        hl, hw = leaf.length / 2.0, leaf.width / 2.0
        outline = np.concatenate([
            Lc + np.outer(LEAF_S * hl, A) + np.outer(LEAF_W * hw, B),
            Lc + np.outer(LEAF_S[::-1] * hl, A) - np.outer(LEAF_W[::-1] * hw, B)])
        if np.all(outline[:, 2] <= NEAR):
            return
        if np.all(outline[:, 2] > NEAR):
            # rasterise the projected outline (exact for a planar shape up to the polygon's
            # sampling, drawn 1 px wider), then intersect rays only inside it
            uv = ctx.camera.project(outline)
            box = ctx.clip_box(int(math.floor(uv[:, 0].min())) - 2,
                               int(math.ceil(uv[:, 0].max())) + 3,
                               int(math.floor(uv[:, 1].min())) - 2,
                               int(math.ceil(uv[:, 1].max())) + 3)
            if box is None:
                return
            u0, u1, v0, v1 = box
            mask = np.zeros((v1 - v0, u1 - u0), np.uint8)
            poly = np.round((uv - [u0, v0]) * 16).astype(np.int32)
            cv2.fillPoly(mask, [poly], 1, cv2.LINE_8, 4)
            cv2.polylines(mask, [poly], True, 1, 2, cv2.LINE_8, 4)
            iy, ix = np.nonzero(mask)
        else:
            u0, u1, v0, v1 = ctx.full_box()
            iy, ix = np.nonzero(np.ones((v1 - v0, u1 - u0), bool))
        if iy.size == 0:
            return
        X = ctx.xs[u0 + ix]
        Y = ctx.ys[v0 + iy]
        denom = X * np.float32(N[0]) + Y * np.float32(N[1]) + np.float32(N[2])
        with np.errstate(divide='ignore', invalid='ignore'):
            z = np.float32(Lc.dot(N)) / denom
        ok = (z > NEAR) & (z < ctx.zbuf[v0 + iy, u0 + ix])
        iy, ix, z = iy[ok], ix[ok], z[ok]
        if iy.size == 0:
            return
        zz = z
        P = np.stack([ctx.xs[u0 + ix] * zz, ctx.ys[v0 + iy] * zz, zz], axis=1)
        D = P - Lc.astype(np.float32)
        s = D.dot(A.astype(np.float32)) / np.float32(hl)
        w = D.dot(B.astype(np.float32)) / np.float32(hw)
        prof = leaf_profile(s)
        inside = (np.abs(s) <= 1.0) & (np.abs(w) <= prof)
        if not inside.any():
            return
        iy, ix, zz, s, w = iy[inside], ix[inside], zz[inside], s[inside], w[inside]
        th, tw = self.leaf_tex.shape
        tex = self.leaf_tex[((s + 1.0) * 0.5 * (th - 1)).astype(np.int32),
                            ((w + 1.0) * 0.5 * (tw - 1)).astype(np.int32) % tw]
        vein = (np.abs(w) < 0.05) | (np.abs(((s * 4.0 + np.abs(w) * 2.0) % 1.0) - 0.5) < 0.04)
        col = rgb_to_bgr(leaf.colour)[None, :] * (1.0 + 0.12 * tex)[:, None]
        col[vein] *= 1.25
        nd = float(N.dot(-ctx.light_cam))
        # two-sided leaf: lit face, or light shining through (translucent)
        lit = abs(nd) * (1.0 if nd * N.dot(-Lc) > 0 else 0.45)
        out = col * (self.ambient_bgr + self.light_bgr * np.float32(lit))[None, :]
        ctx.put(v0 + iy, u0 + ix, zz, out, label)

    def _capsule(self, ctx, a_map, b_map, radius, rgb, label):
        A, B = ctx.to_cam(a_map), ctx.to_cam(b_map)
        if A[2] <= NEAR and B[2] <= NEAR:
            return
        if A[2] <= NEAR or B[2] <= NEAR:          # clip the segment at the near plane
            if A[2] <= NEAR:
                A, B = B, A
            s = (A[2] - 2 * NEAR) / (A[2] - B[2])
            B = A + s * (B - A)
        zmin = max(min(A[2], B[2]) - radius, NEAR)
        rp = ctx.camera.fx * radius / zmin + 2.0
        uv = ctx.camera.project(np.array([A, B]))
        u0 = int(math.floor(uv[:, 0].min() - rp))
        u1 = int(math.ceil(uv[:, 0].max() + rp)) + 1
        v0 = int(math.floor(uv[:, 1].min() - rp))
        v1 = int(math.ceil(uv[:, 1].max() + rp)) + 1
        box = ctx.clip_box(u0, u1, v0, v1)
        if box is None:
            return
        u0, u1, v0, v1 = box
        X = ctx.xs[u0:u1][None, :]
        Y = ctx.ys[v0:v1][:, None]
        V = (B - A).astype(np.float32)
        A32 = A.astype(np.float32)
        a = X * X + Y * Y + np.float32(1.0)
        b = X * V[0] + Y * V[1] + V[2]
        c = np.float32(V.dot(V))
        dA = X * A32[0] + Y * A32[1] + A32[2]
        vA = np.float32(V.dot(A32))
        denom = a * c - b * b
        with np.errstate(divide='ignore', invalid='ignore'):
            s = np.where(denom > 1e-12, (b * dA - a * vA) / denom, 0.0)
        s = np.clip(s, 0.0, 1.0)
        t = (b * s + dA) / a                       # ray parameter (= depth) closest to Q(s)
        dx = X * t - (A32[0] + s * V[0])
        dy = Y * t - (A32[1] + s * V[1])
        dz = t - (A32[2] + s * V[2])
        dist2 = dx * dx + dy * dy + dz * dz
        hit = dist2 < np.float32(radius * radius)
        if not hit.any():
            return
        front = np.sqrt(np.maximum(np.float32(radius * radius) - dist2, 0.0) / a)
        z = t - front
        zb = ctx.zbuf[v0:v1, u0:u1]
        hit &= (z > NEAR) & (z < zb)
        iy, ix = np.nonzero(hit)
        if iy.size == 0:
            return
        zz = z[iy, ix]
        # surface normal: from the axis point to the front surface point
        nx = dx[iy, ix] - ctx.xs[u0 + ix] * front[iy, ix]
        ny = dy[iy, ix] - ctx.ys[v0 + iy] * front[iy, ix]
        nz = dz[iy, ix] - front[iy, ix]
        n = np.stack([nx, ny, nz], axis=1)
        n /= np.maximum(np.linalg.norm(n, axis=1), 1e-9)[:, None]
        diff = np.maximum(n.dot(-ctx.light_cam), 0.0)[:, None]
        out = rgb_to_bgr(rgb)[None, :] * (self.ambient_bgr + self.light_bgr * diff)
        ctx.put(v0 + iy, u0 + ix, zz, out, label)
