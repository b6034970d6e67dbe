#!/usr/bin/env python3
"""Renders 4D light fields with exact intrinsic ground truth (issue 21), in the folder layout of
the HCI 4D light field benchmark (Honauer, Johannsen, Kondermann & Goldluecke, ACCV 2016) plus a
`truth/` folder with reflectance, shading and every view's disparity.

    python3 scripts/render_lightfields.py [--out .cache/rendered-lightfields] [--scenes 8]
                                          [--grid 9] [--size 256] [--spp 8]
    python3 scripts/render_lightfields.py --tiny      # rewrites fixtures/lightfield/tiny/
    python3 scripts/render_lightfields.py --seeds 0-7 --split tune   # the split used since
    python3 scripts/render_lightfields.py --seeds 9-16 --split test  # 2026-12-05

Scenes are seeded and split by seed: the first half goes to `tune/`, the second to `test/`
(default: seeds 0-3 tune, 4-7 test), or `--seeds` into `--split`. Since 2026-12-05 the split
is seeds 0-7 tune and 9-16 test (docs/lightfield-data.md). Tune only on `tune/`. `--tiny` renders one scene (seed
`--tiny-seed`, default 8, in neither split) as 5x5 views of 48x48 pixels (16 spp) straight into
`fixtures/lightfield/tiny/` (0.90 MB with its truth).

Each scene is a closed room (no background: every pixel sees a surface) with printed textures
(ink marks on paper, stripes, checks, dots, colour patches; all generated here, so the output is
ours to license), plain coloured, white (0.8) or black (0.04) paint, four to seven objects
(spheres, boxes and printed boards floating in front of the others, so that objects occlude each
other in every view), one white point light (hard cast shadows) and a weaker white fill light,
sometimes with a small area light behind the cameras (soft shadows). All materials are
Lambertian (`diffuse`). Mitsuba 3 (PyPI `mitsuba`, `scalar_rgb`): the `direct` integrator wrapped
in the `aov` integrator renders the image I and the albedo R from the same samples, once per
light, summed (Mitsuba picks one light at random per light sample, which with several lights is
noisy; a point light alone is exact). Direct light only, white lights, so
S = sum_c I_c / sum_c R_c is grey and view-independent (Lambertian), and the input written is
R x S, so I = R x S holds exactly (to 16-bit quantisation: the script checks it and prints the
largest error in 16-bit steps). At a pixel that mixes two surfaces the written input is R x S of
the pixel's mean albedo and shading, not the rendered mixture: the product is what is exact.

Camera grid (the HCI geometry, as in their Blender add-on `lightfield_simulator.py`): `grid x
grid` pinhole cameras on a plane, parallel optical axes, camera (row, col) at
centre + (col - c0) * b * right - (row - r0) * b * up (row 0 at the top, col 0 at the left, views
numbered row-major `input_Cam{row*grid+col:03d}`), each with its principal point shifted so that
the plane at `focus_distance_m` has zero disparity. Disparity in pixels, HCI's formula
(`depth2disp` in their evaluation toolkit): d = b f_px (1/Z - 1/focus), f_px =
focal_length_mm / sensor_size_mm * max(width, height), Z the planar depth along the optical axis.
The convention that follows, and that `decompose::lightfield::corresponding` implements:

    a point with disparity d at pixel (x, y) of view (r, c) appears at
    (x - (c' - c) d, y - (r' - r) d) in view (r', c')

(x to the right, y down, pixel centres at integer + 0.5 in Mitsuba's film, integers in the Rust
code; the offset is the same). Positive disparity is nearer than the focus plane. The script
checks the convention against the renderer: it warps the centre view's world positions into the
corner views by the true disparity and prints the median position error in pixels.

Per scene folder:
    input_Cam000.png ... input_CamNNN.png   8-bit sRGB, the input R x S
    parameters.cfg                            HCI's INI keys ([intrinsics] [extrinsics] [meta])
    gt_disp_lowres.pfm, gt_depth_lowres.pfm  centre view disparity (px) and planar depth (m)
    truth/input/input_CamNNN.png              16-bit linear RGB, R x S
    truth/reflectance/input_CamNNN.png        16-bit linear RGB albedo R
    truth/shading/input_CamNNN.png            16-bit linear grey S (one scale per scene)
    truth/disparity/input_CamNNN.pfm          every view's disparity (px)
PFM as HCI writes it: `Pf`, `W H`, scale -1 (little-endian), rows bottom to top. Disparity and
depth are sampled at pixel centres (one non-jittered sample); colours are box-filtered over the
pixel with `--spp` samples. No mask is written: the rooms are closed, every pixel is a surface.

The baseline is chosen per scene so that the 1st to 99th percentile of the centre view's
disparity spans about +-`--max-disparity` pixels (default 1.5, the range where structure-tensor
EPI depth is reliable) at any `--size`; the focus plane sits at the harmonic middle of that depth
range.
"""

import argparse
import datetime
import json
import math
import os
import struct
import sys
import tempfile
import time
import zlib

import numpy as np

from procedural_textures import TEXTURES

try:
    import mitsuba as mi
except ImportError:
    sys.exit("mitsuba is not installed: python3 -m pip install --user mitsuba")

mi.set_variant("scalar_rgb")
T = mi.ScalarTransform4f

FOCAL_LENGTH_MM = 35.0
SENSOR_SIZE_MM = 36.0
ROOM = {"x": 3.0, "y": 4.0, "z_back": -3.0, "z_front": 5.5}
CAMERA_CENTRE = np.array([0.0, 1.5, 4.0])
CAMERA_TARGET = np.array([0.0, 1.0, -1.5])
UP = np.array([0.0, 1.0, 0.0])


# ---- files ----


# Set by --tiny: try every PNG row filter at zlib level 9 (the committed fixture must stay small);
# otherwise the Paeth filter at level 6, which is close and five times faster.
PNG_EFFORT = {"filters": (4,), "level": 6}


def _png(path, a, bit_depth, srgb):
    """Writes a uint8/uint16 array (H, W) or (H, W, 3) as a PNG with the smallest of the row
    filters in PNG_EFFORT (Mitsuba's writer compresses 16-bit data poorly). `srgb` adds an sRGB
    chunk; linear files carry no colour chunk at all."""
    h, w = a.shape[:2]
    channels = 1 if a.ndim == 2 else a.shape[2]
    colour_type = 0 if channels == 1 else 2
    dtype = ">u2" if bit_depth == 16 else "u1"
    raw = np.ascontiguousarray(a.astype(dtype)).view(np.uint8).reshape(h, -1).astype(np.int32)
    bpp = channels * bit_depth // 8
    left = np.zeros_like(raw)
    left[:, bpp:] = raw[:, :-bpp]
    up = np.zeros_like(raw)
    up[1:] = raw[:-1]
    upleft = np.zeros_like(raw)
    upleft[1:, bpp:] = raw[:-1, :-bpp]
    p = left + up - upleft
    pa, pb, pc = np.abs(p - left), np.abs(p - up), np.abs(p - upleft)
    paeth = np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, up, upleft))
    candidates = [raw, raw - left, raw - up, raw - (left + up) // 2, raw - paeth]
    best = None
    for ftype in PNG_EFFORT["filters"]:
        rows = np.concatenate([np.full((h, 1), ftype, np.int32), candidates[ftype] & 0xFF], axis=1)
        data = zlib.compress(rows.astype(np.uint8).tobytes(), PNG_EFFORT["level"])
        if best is None or len(data) < len(best):
            best = data

    def chunk(tag, body):
        return struct.pack(">I", len(body)) + tag + body + struct.pack(">I", zlib.crc32(tag + body))

    out = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, bit_depth, colour_type, 0, 0, 0))
    if srgb:
        out += chunk(b"sRGB", b"\x00")
    out += chunk(b"IDAT", best) + chunk(b"IEND", b"")
    with open(path, "wb") as f:
        f.write(out)


def quantise16(a):
    return np.round(np.clip(a, 0.0, 1.0) * 65535.0).astype(np.uint16)


def save16(path, a):
    """A float image in [0, 1] as a 16-bit linear PNG (grey or RGB)."""
    _png(path, quantise16(a), 16, srgb=False)


def srgb_encode(a):
    a = np.clip(a, 0.0, 1.0)
    return np.where(a <= 0.0031308, 12.92 * a, 1.055 * np.power(a, 1 / 2.4) - 0.055)


def save8_srgb(path, a):
    """A linear float RGB image in [0, 1] as an 8-bit sRGB PNG."""
    _png(path, np.round(srgb_encode(a) * 255.0).astype(np.uint8), 8, srgb=True)


def save_pfm(path, a):
    """HCI's PFM: grey `Pf`, scale -1 (little-endian floats), rows stored bottom to top."""
    h, w = a.shape
    with open(path, "wb") as f:
        f.write(b"Pf\n%d %d\n-1\n" % (w, h))
        f.write(np.ascontiguousarray(np.flipud(a), dtype="<f4").tobytes())


# ---- printed textures (procedural_textures.py; saved as 8-bit sRGB PNGs that Mitsuba decodes
# to linear) and plain paints ----


def paint(rng):
    """A plain paint: coloured, white or black."""
    kind = ["colour", "colour", "white", "black"][int(rng.integers(0, 4))]
    if kind == "white":
        return np.full(3, 0.8), "white"
    if kind == "black":
        return np.full(3, 0.04), "black"
    c = rng.uniform(0.05, 0.8, 3)
    c[rng.integers(0, 3)] = rng.uniform(0.6, 0.9)
    return c, "colour"


def material(rng, tmp, name, textured_probability):
    if rng.random() < textured_probability:
        tex = TEXTURES[int(rng.integers(0, len(TEXTURES)))](rng)
        path = os.path.join(tmp, name + ".png")
        save8_srgb(path, tex)
        return {"type": "diffuse", "reflectance": {"type": "bitmap", "filename": path}}, "texture"
    c, kind = paint(rng)
    return {"type": "diffuse", "reflectance": {"type": "rgb", "value": c.tolist()}}, kind


# ---- scenes ----


def scene_dict(seed, tmp):
    """The room, objects and lights of scene `seed` (no sensor, no integrator)."""
    rng = np.random.default_rng(seed)
    d = {"type": "scene"}
    kinds = {}
    X, Y, zb, zf = ROOM["x"], ROOM["y"], ROOM["z_back"], ROOM["z_front"]
    zc, hz = (zb + zf) / 2, (zf - zb) / 2
    # Rectangles face +z locally; every wall's normal points into the room (diffuse is one-sided).
    walls = {
        "floor": T.translate([0, 0, zc]).rotate([1, 0, 0], -90).scale([X, hz, 1]),
        "ceiling": T.translate([0, Y, zc]).rotate([1, 0, 0], 90).scale([X, hz, 1]),
        "back": T.translate([0, Y / 2, zb]).scale([X, Y / 2, 1]),
        "front": T.translate([0, Y / 2, zf]).rotate([0, 1, 0], 180).scale([X, Y / 2, 1]),
        "left": T.translate([-X, Y / 2, zc]).rotate([0, 1, 0], 90).scale([hz, Y / 2, 1]),
        "right": T.translate([X, Y / 2, zc]).rotate([0, 1, 0], -90).scale([hz, Y / 2, 1]),
    }
    for name, tf in walls.items():
        bsdf, kind = material(rng, tmp, name, 0.6 if name in ("floor", "back") else 0.3)
        kinds[name] = kind
        d[name] = {"type": "rectangle", "to_world": tf, "bsdf": bsdf}
    n_objects = int(rng.integers(4, 8))
    for i in range(n_objects):
        shape = ["sphere", "cube", "board"][int(rng.integers(0, 3))]
        s = rng.uniform(0.25, 0.55)
        # Half the objects stand near the back, half nearer the cameras, so they occlude.
        near = i % 2 == 1
        x = rng.uniform(-1.6, 1.6) if near else rng.uniform(-2.2, 2.2)
        z = rng.uniform(0.3, 1.8) if near else rng.uniform(-2.4, -0.3)
        bsdf, kind = material(rng, tmp, f"object{i}", 1.0 if shape == "board" else 0.45)
        kinds[f"object{i}"] = f"{shape}/{kind}"
        if shape == "sphere":
            y = s if rng.random() < 0.6 else rng.uniform(0.8, 2.0)
            d[f"object{i}"] = {"type": "sphere", "to_world": T.translate([x, y, z]).scale(s), "bsdf": bsdf}
        elif shape == "cube":
            tf = T.translate([x, s, z]).rotate([0, 1, 0], rng.uniform(0, 90)).scale(s)
            d[f"object{i}"] = {"type": "cube", "to_world": tf, "bsdf": bsdf}
        else:  # a thin printed board floating upright, turned a little towards the cameras
            y = rng.uniform(0.9, 2.0)
            tf = T.translate([x, y, z]).rotate([0, 1, 0], rng.uniform(-30, 30)).scale([1.3 * s, 1.3 * s, 0.02])
            d[f"object{i}"] = {"type": "cube", "to_world": tf, "bsdf": bsdf}
    light = [rng.uniform(-2.0, 2.0), rng.uniform(2.6, 3.2), rng.uniform(-1.5, 2.5)]
    d["point"] = {"type": "point", "position": light, "intensity": {"type": "rgb", "value": [10.0, 10.0, 10.0]}}
    # A weaker white fill light on the other side, so that few surfaces are in full darkness
    # (with direct light only, a surface no light reaches has S = 0 and hides its reflectance).
    fill = [-light[0] * rng.uniform(0.5, 1.0), rng.uniform(2.0, 3.0), rng.uniform(2.0, 4.5)]
    d["fill"] = {"type": "point", "position": fill, "intensity": {"type": "rgb", "value": [3.0, 3.0, 3.0]}}
    area = bool(rng.random() < 0.4)
    if area:  # behind and above the cameras, facing down, out of every view
        d["area"] = {
            "type": "rectangle",
            "to_world": T.translate([rng.uniform(-1.5, 1.5), Y - 0.05, zf - 0.8]).rotate([1, 0, 0], 90).scale(0.4),
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [8.0, 8.0, 8.0]}},
        }
    return d, {"objects": n_objects, "area_light": area, "surfaces": kinds, "point_light": light, "fill_light": fill}


def sampler(spp, seed, centre_only):
    """Mitsuba sampler: one unjittered sample at each pixel centre (for the position AOV that
    the exact disparity and flow come from), else `spp` independent seeded samples."""
    if centre_only:
        return {"type": "stratified", "sample_count": 1, "jitter": False}
    return {"type": "independent", "sample_count": spp, "seed": seed}


class Rig:
    """The camera grid: HCI geometry (see the module docstring)."""

    def __init__(self, grid, size, seed):
        rng = np.random.default_rng(10_000 + seed)
        self.grid, self.size = grid, size
        self.centre = CAMERA_CENTRE + np.array([rng.uniform(-0.4, 0.4), rng.uniform(-0.2, 0.2), 0.0])
        target = CAMERA_TARGET + np.array([rng.uniform(-0.5, 0.5), 0.0, 0.0])
        self.forward = (target - self.centre) / np.linalg.norm(target - self.centre)
        self.right = np.cross(self.forward, UP)
        self.right /= np.linalg.norm(self.right)
        self.up = np.cross(self.right, self.forward)
        self.f_px = FOCAL_LENGTH_MM / SENSOR_SIZE_MM * size
        self.fov = math.degrees(2 * math.atan(SENSOR_SIZE_MM / 2 / FOCAL_LENGTH_MM))
        self.c0 = (grid - 1) / 2
        self.baseline_m = 0.0
        self.focus_m = 1.0

    def position(self, row, col):
        return self.centre + (col - self.c0) * self.baseline_m * self.right - (row - self.c0) * self.baseline_m * self.up

    def sensor(self, row, col, spp, seed, centre_only=False):
        """Mitsuba sensor of view (row, col). `principal_point_offset_x` is a fraction of the film
        width and moves the frustum to the image's +x (right); `_y` moves it to the image's +y
        (down). Zero disparity on the focus plane needs a shift of -(col - c0) b f / focus pixels
        in x and -(row - c0) b f / focus in y (a camera to the right looks a little left)."""
        shift = self.baseline_m * self.f_px / self.focus_m
        o = self.position(row, col)
        return {
            "type": "perspective",
            "fov": self.fov,
            "fov_axis": "x",
            "principal_point_offset_x": -(col - self.c0) * shift / self.size,
            "principal_point_offset_y": -(row - self.c0) * shift / self.size,
            "to_world": T.look_at(origin=o.tolist(), target=(o + self.forward).tolist(), up=self.up.tolist()),
            "film": {"type": "hdrfilm", "width": self.size, "height": self.size, "rfilter": {"type": "box"}},
            "sampler": sampler(spp, seed, centre_only),
        }

    def depth(self, positions, row, col):
        """Planar depth Z along the optical axis of view (row, col)."""
        return (positions - self.position(row, col)) @ self.forward

    def disparity(self, z):
        """HCI's depth2disp: d = b f_px (1/Z - 1/focus)."""
        return self.baseline_m * self.f_px * (1.0 / z - 1.0 / self.focus_m)

    def euler_xyz(self):
        """Blender-style XYZ Euler angles (rad) of a camera looking along its -z, in this script's
        world frame (y up), for the `center_cam_r*_rad` keys."""
        r = np.stack([self.right, self.up, -self.forward], axis=1)
        return math.atan2(r[2, 1], r[2, 2]), -math.asin(max(-1.0, min(1.0, r[2, 0]))), math.atan2(r[1, 0], r[0, 0])


POSITION = None


def positions_at_centres(scene, rig, row, col):
    """World positions seen through the centre of every pixel of view (row, col)."""
    global POSITION
    if POSITION is None:
        POSITION = mi.load_dict({"type": "aov", "aovs": "pos:position"})
    sensor = mi.load_dict(rig.sensor(row, col, 1, 0, centre_only=True))
    return np.array(mi.render(scene, sensor=sensor, integrator=POSITION, spp=1))[..., 0:3].astype(np.float64)


def bilinear(img, x, y):
    """Samples img (H, W, C) at pixel coordinates (x, y) with pixel centres at integers."""
    h, w = img.shape[:2]
    x = np.clip(x, 0, w - 1.001)
    y = np.clip(y, 0, h - 1.001)
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    return (
        img[y0, x0] * (1 - fx) * (1 - fy)
        + img[y0, x0 + 1] * fx * (1 - fy)
        + img[y0 + 1, x0] * (1 - fx) * fy
        + img[y0 + 1, x0 + 1] * fx * fy
    )


def render(seed, out_dir, tmp, grid, size, spp, max_disparity, split, log):
    t_start = time.time()
    scene_d, info = scene_dict(seed, tmp)
    # One scene per light, rendered separately and summed: Mitsuba's `direct` integrator picks
    # one emitter at random per light sample, which with two or three lights and a few samples
    # per pixel is very noisy; a point light alone is sampled exactly. The area light's
    # rectangle stays in the other scenes as a plain surface, so every scene has one geometry.
    lights = [k for k in ("point", "fill", "area") if k in scene_d]
    base = {k: v for k, v in scene_d.items() if k not in lights}
    scenes = []
    for name in lights:
        d = dict(base)
        d[name] = scene_d[name]
        if name != "area" and "area" in scene_d:
            d["area"] = {k: v for k, v in scene_d["area"].items() if k != "emitter"}
        scenes.append((name, mi.load_dict(d)))
    scene = scenes[0][1]
    rig = Rig(grid, size, seed)
    c = grid // 2
    # Focus and baseline from the centre view's depth (the centre camera does not depend on them).
    z = rig.depth(positions_at_centres(scene, rig, c, c), c, c)
    z_near, z_far = np.percentile(z, 1), np.percentile(z, 99)
    rig.focus_m = 2.0 / (1.0 / z_near + 1.0 / z_far)
    rig.baseline_m = max_disparity / (rig.f_px * (1.0 / z_near - 1.0 / rig.focus_m))

    names = [f"input_Cam{i:03d}" for i in range(grid * grid)]
    for sub in ("input", "reflectance", "shading", "disparity"):
        os.makedirs(os.path.join(out_dir, "truth", sub), exist_ok=True)
    # The area light's soft shadows need more light samples than a point light, which one sample
    # gives exactly.
    integrators = {
        name: mi.load_dict(
            {
                "type": "aov",
                "aovs": "albedo:albedo",
                "integrator": {"type": "direct", "emitter_samples": 8 if name == "area" else 1, "bsdf_samples": 0},
            }
        )
        for name, _ in scenes
    }
    views, disparities, positions = [], [], {}
    for row in range(grid):
        for col in range(grid):
            i = row * grid + col
            sensor = mi.load_dict(rig.sensor(row, col, spp, seed * 1000 + i))
            # The same seed for every light: the same sub-pixel samples, so the albedo AOVs agree.
            out = sum(
                np.array(mi.render(sc, sensor=sensor, integrator=integrators[name], seed=seed * 1000 + i, spp=spp)).astype(np.float64)
                for name, sc in scenes
            )
            out[..., 3:6] /= len(scenes)
            image, albedo = out[..., 0:3], out[..., 3:6]
            pos = positions_at_centres(scene, rig, row, col)
            positions[(row, col)] = pos
            disparities.append(rig.disparity(rig.depth(pos, row, col)))
            views.append((image, albedo))
            if log:
                print(f"\r  view {i + 1}/{grid * grid}", end="", flush=True)
    if log:
        print("\r", end="")

    # One shading scale per scene, so that S is comparable across views: the largest S seen.
    shadings = [im.sum(-1) / np.maximum(al.sum(-1), 1e-6) for im, al in views]
    smax = max(s.max() for s in shadings)
    worst = 0.0
    for name, (image, albedo), s, disp in zip(names, views, shadings, disparities):
        refl = np.clip(albedo, 0.0, 1.0)
        shading = s / smax
        product = refl * shading[..., None]
        save16(os.path.join(out_dir, "truth", "input", name + ".png"), product)
        save16(os.path.join(out_dir, "truth", "reflectance", name + ".png"), refl)
        save16(os.path.join(out_dir, "truth", "shading", name + ".png"), shading)
        save_pfm(os.path.join(out_dir, "truth", "disparity", name + ".pfm"), disp.astype(np.float32))
        save8_srgb(os.path.join(out_dir, name + ".png"), product)
        # What a reader of the 16-bit files sees: |Q(R) Q(S) - Q(R S)| in 16-bit steps.
        rq = quantise16(refl) / 65535.0
        sq = quantise16(shading) / 65535.0
        iq = quantise16(product) / 65535.0
        worst = max(worst, float(np.abs(rq * sq[..., None] - iq).max() * 65535.0))
    centre = c * grid + c
    save_pfm(os.path.join(out_dir, "gt_disp_lowres.pfm"), disparities[centre].astype(np.float32))
    save_pfm(os.path.join(out_dir, "gt_depth_lowres.pfm"), rig.depth(positions[(c, c)], c, c).astype(np.float32))

    # Convention check against the renderer: the centre view's world positions, warped to each
    # corner view by the true disparity, must land where that view sees the same point.
    xs, ys = np.meshgrid(np.arange(size, dtype=np.float64), np.arange(size, dtype=np.float64))
    dc = disparities[centre]
    errors = []
    for r2, c2 in [(0, 0), (0, grid - 1), (grid - 1, 0), (grid - 1, grid - 1)]:
        x2 = xs - (c2 - c) * dc
        y2 = ys - (r2 - c) * dc
        inside = (x2 >= 0) & (x2 <= size - 1) & (y2 >= 0) & (y2 <= size - 1)
        seen = bilinear(positions[(r2, c2)], x2, y2)
        footprint = rig.depth(positions[(c, c)], c, c) / rig.f_px  # metres per pixel
        err = np.linalg.norm(seen - positions[(c, c)], axis=-1) / footprint
        errors.append(err[inside])
    convention_px = float(np.median(np.concatenate(errors)))

    lo = math.floor(float(min(d.min() for d in disparities)) * 10) / 10 - 0.1
    hi = math.ceil(float(max(d.max() for d in disparities)) * 10) / 10 + 0.1
    rx, ry, rz = rig.euler_xyz()
    cfg = f"""[intrinsics]
focal_length_mm = {FOCAL_LENGTH_MM}
image_resolution_x_px = {size}
image_resolution_y_px = {size}
sensor_size_mm = {SENSOR_SIZE_MM}
fstop = 100.0

[extrinsics]
num_cams_x = {grid}
num_cams_y = {grid}
baseline_mm = {float(rig.baseline_m * 1000.0)!r}
focus_distance_m = {float(rig.focus_m)!r}
center_cam_x_m = {float(rig.centre[0])!r}
center_cam_y_m = {float(rig.centre[1])!r}
center_cam_z_m = {float(rig.centre[2])!r}
center_cam_rx_rad = {rx!r}
center_cam_ry_rad = {ry!r}
center_cam_rz_rad = {rz!r}

[meta]
scene = {os.path.basename(out_dir)}
category = {split}
date = {datetime.date.today().isoformat()}
version = v1.0
authors = rendered by scripts/render_lightfields.py (Mitsuba {mi.__version__}, {mi.variant()}), seed {seed}
contact = none
cycles_seed = {seed}
disp_min = {lo:.1f}
disp_max = {hi:.1f}
frustum_disp_min = {-max_disparity:.1f}
frustum_disp_max = {max_disparity:.1f}
depth_map_scale = 1.0
"""
    with open(os.path.join(out_dir, "parameters.cfg"), "w") as f:
        f.write(cfg)
    info.update(
        seed=seed,
        baseline_mm=rig.baseline_m * 1000.0,
        focus_distance_m=rig.focus_m,
        disp_min=float(min(d.min() for d in disparities)),
        disp_max=float(max(d.max() for d in disparities)),
        product_error_16bit_steps=worst,
        convention_median_error_px=convention_px,
        seconds=time.time() - t_start,
    )
    return info


def parse_seeds(text):
    """`2-7`, `2,5,9` or a mix (`0-3,9`) as a sorted list of distinct seeds."""
    seeds = set()
    try:
        for part in text.split(","):
            lo, _, hi = part.strip().partition("-")
            lo = int(lo)
            hi = int(hi) if hi else lo
            if lo < 0 or hi < lo:
                raise ValueError
            seeds.update(range(lo, hi + 1))
    except ValueError:
        sys.exit(f"--seeds: expected ranges like 2-7 or 2,5,9, got {text!r}")
    return sorted(seeds)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=".cache/rendered-lightfields", help="output root (tune/ and test/ below it)")
    p.add_argument("--scenes", type=int, default=8, help="number of seeded scenes, half tune, half test")
    p.add_argument("--grid", type=int, default=9, help="views per row and per column (odd)")
    p.add_argument("--size", type=int, default=256, help="width and height of every view, pixels")
    p.add_argument("--spp", type=int, default=4, help="samples per pixel of the colour render")
    p.add_argument("--max-disparity", type=float, default=1.5, help="disparity (px) at the 1st/99th depth percentile")
    p.add_argument("--tiny", action="store_true", help="render the committed fixture: 5x5 views of 48x48, one scene")
    p.add_argument("--tiny-seed", type=int, default=8, help="seed of the fixture scene (8: in neither split)")
    p.add_argument("--seeds", help="render these seeds only (e.g. 2-7 or 2,5,9) into --split; overrides --scenes")
    p.add_argument("--split", choices=("tune", "test"), help="the split --seeds go to")
    a = p.parse_args()
    if a.tiny:
        a.grid, a.size, a.spp = 5, 48, 16
        PNG_EFFORT.update(filters=(0, 1, 2, 3, 4), level=9)
        jobs = [(a.tiny_seed, "fixture", os.path.join("fixtures", "lightfield", "tiny"))]
    elif a.seeds:
        if not a.split:
            sys.exit("--seeds needs --split tune or --split test")
        seeds = parse_seeds(a.seeds)
        if a.tiny_seed in seeds:
            print(f"warning: seed {a.tiny_seed} is the committed fixture's scene", file=sys.stderr)
        jobs = [(seed, a.split, os.path.join(a.out, a.split, f"scene{seed:02d}")) for seed in seeds]
    else:
        if a.scenes < 2:
            sys.exit("--scenes: at least 2 (half tune, half test)")
        jobs = []
        for seed in range(a.scenes):
            split = "tune" if seed < a.scenes // 2 else "test"
            jobs.append((seed, split, os.path.join(a.out, split, f"scene{seed:02d}")))
    if a.grid < 3 or a.grid % 2 == 0:
        sys.exit("--grid: an odd number >= 3 (the centre view must exist)")
    if a.size < 8:
        sys.exit("--size: at least 8")
    provenance = {
        "mitsuba": mi.__version__,
        "variant": mi.variant(),
        "grid": a.grid,
        "size": a.size,
        "spp": a.spp,
        "max_disparity": a.max_disparity,
        "scenes": {},
    }
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        for k, (seed, split, out_dir) in enumerate(jobs):
            print(f"[{k + 1}/{len(jobs)}] {out_dir} ({a.grid}x{a.grid} views of {a.size}x{a.size}, {a.spp} spp)", flush=True)
            info = render(seed, out_dir, tmp, a.grid, a.size, a.spp, a.max_disparity, split, log=True)
            provenance["scenes"][out_dir] = info
            print(
                f"  {info['objects']} objects, area light {info['area_light']}, disparity "
                f"[{info['disp_min']:.2f}, {info['disp_max']:.2f}] px, focus {info['focus_distance_m']:.2f} m, "
                f"baseline {info['baseline_mm']:.1f} mm; |R x S - I| <= {info['product_error_16bit_steps']:.2f} "
                f"16-bit steps; convention check: median {info['convention_median_error_px']:.3f} px; "
                f"{info['seconds']:.0f} s",
                flush=True,
            )
    print(f"done in {time.time() - t0:.0f} s", flush=True)
    if not a.tiny:
        name = f"provenance-{a.split}-{a.seeds}.json" if a.seeds else "provenance.json"
        with open(os.path.join(a.out, name), "w") as f:
            json.dump(provenance, f, indent=1)


if __name__ == "__main__":
    main()
