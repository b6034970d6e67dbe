#!/usr/bin/env python3
"""Renders indoor scenes with exact intrinsic ground truth (issue 19), in the MIT layout that
`decompose eval --mit DIR` reads: per scene `diffuse.png` (input), `reflectance.png`,
`shading.png` and `mask.png`, 16-bit linear PNGs.

    python3 scripts/render_intrinsic_scenes.py [--out .cache/rendered-scenes] [--scenes 24]

Scenes are seeded and split by seed: the first half goes to `tune/`, the second to `test/`.
Tune only on `tune/`; report `test/` and never look at it while tuning.

Each scene is a room (floor, back wall, two side walls) with printed textures (ink lines and
text-like marks on paper, stripes, checks, dots, colour patches) or plain coloured, white or
black paint, three to six objects (spheres, boxes, printed boards leaning on the back wall) and one or two white lights
(a point light for hard cast shadows, sometimes a small area light for soft ones), all
Lambertian (`diffuse`). Mitsuba 3 (PyPI `mitsuba`, `scalar_rgb`): the `direct` integrator
renders the image I (direct light only, so I = R × S holds for white lights), the `aov`
integrator the albedo R. Shading S = Σ_c I_c / Σ_c R_c, grey; the input written is R × S, so the
product holds exactly at every masked pixel (at occlusion edges a pixel mixes surfaces and the
rendered I differs from R × S by the mixing; those pixels are masked out as well). The mask keeps
pixels that see the room (not the void beyond it), have albedo above 0.02 in every channel
(black paint is 0.04) and no depth step of more than 5% to a 4-neighbour.
"""

import argparse
import json
import math
import os
import sys
import tempfile

import numpy as np

from procedural_textures import TEXTURES

try:
    import mitsuba as mi
except ImportError:
    sys.exit("mitsuba is not installed: python3 -m pip install --user mitsuba")

mi.set_variant("scalar_rgb")
T = mi.ScalarTransform4f

WIDTH, HEIGHT = 320, 240


def save16(path, a):
    """Writes a float image in [0, 1] as a 16-bit linear PNG (grey or RGB)."""
    a = np.ascontiguousarray(np.clip(a, 0.0, 1.0), dtype=np.float32)
    fmt = mi.Bitmap.PixelFormat.Y if a.ndim == 2 else mi.Bitmap.PixelFormat.RGB
    b = mi.Bitmap(a, fmt)
    b.convert(fmt, mi.Struct.Type.UInt16, srgb_gamma=False).write(path)


def save8_srgb(path, a):
    """Writes a linear float RGB image in [0, 1] as an 8-bit sRGB PNG."""
    a = np.ascontiguousarray(np.clip(a, 0.0, 1.0), dtype=np.float32)
    b = mi.Bitmap(a, mi.Bitmap.PixelFormat.RGB)
    b.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True).write(path)


# ---- printed textures (procedural_textures.py; saved as 8-bit sRGB PNGs that Mitsuba decodes
# to linear) and plain paints ----


def paint(rng):
    """A plain paint: coloured, white or black."""
    kind = rng.choice(["colour", "colour", "white", "black"])
    if kind == "white":
        return np.full(3, rng.uniform(0.75, 0.85))
    if kind == "black":
        return np.full(3, 0.04)
    c = rng.uniform(0.05, 0.8, 3)
    c[rng.integers(0, 3)] = rng.uniform(0.6, 0.9)
    return c


def material(rng, tmp, name, textured_probability):
    if rng.random() < textured_probability:
        tex = TEXTURES[int(rng.integers(0, len(TEXTURES)))](rng)
        path = os.path.join(tmp, name + ".png")
        save8_srgb(path, tex)
        return {"type": "diffuse", "reflectance": {"type": "bitmap", "filename": path}}, "texture"
    c = paint(rng)
    return {"type": "diffuse", "reflectance": {"type": "rgb", "value": c.tolist()}}, "paint"


def scene_dict(seed, tmp):
    rng = np.random.default_rng(seed)
    d = {"type": "scene"}
    kinds = []
    walls = {
        "floor": T.rotate([1, 0, 0], -90).scale([4, 4, 1]),
        "back": T.translate([0, 2, -3]).scale([4, 2, 1]),
        "left": T.translate([-3, 2, 0]).rotate([0, 1, 0], 90).scale([4, 2, 1]),
        "right": T.translate([3, 2, 0]).rotate([0, 1, 0], -90).scale([4, 2, 1]),
    }
    for name, tf in walls.items():
        bsdf, kind = material(rng, tmp, name, 0.5)
        kinds.append(kind)
        d[name] = {"type": "rectangle", "to_world": tf, "bsdf": bsdf}
    n_objects = int(rng.integers(3, 7))
    for i in range(n_objects):
        shape = rng.choice(["sphere", "cube", "poster"])
        s = rng.uniform(0.3, 0.6)
        x, z = rng.uniform(-1.8, 1.8), rng.uniform(-2.2, 0.8)
        bsdf, kind = material(rng, tmp, f"object{i}", 0.4)
        kinds.append(kind)
        if shape == "sphere":
            tf = T.translate([x, s, z]).scale(s)
        elif shape == "cube":
            tf = T.translate([x, s, z]).rotate([0, 1, 0], rng.uniform(0, 90)).scale(s)
        else:  # a thin printed board leaning on the back wall
            bsdf, kind = material(rng, tmp, f"object{i}", 1.0)
            kinds[-1] = kind
            tf = T.translate([x, 2 * s + 0.05, -2.9]).rotate([1, 0, 0], -8).scale([1.4 * s, 2 * s, 0.03])
            shape = "cube"
        d[f"object{i}"] = {"type": shape, "to_world": tf, "bsdf": bsdf}
    lx, lz = rng.uniform(-2, 2), rng.uniform(-1.5, 2.5)
    d["point"] = {
        "type": "point",
        "position": [lx, rng.uniform(2.4, 3.4), lz],
        "intensity": {"type": "rgb", "value": [12.0, 12.0, 12.0]},
    }
    area = rng.random() < 0.5
    if area:
        ax = rng.uniform(-2, 2)
        d["area"] = {
            "type": "rectangle",
            "to_world": T.translate([ax, 3.9, 2.0]).rotate([1, 0, 0], 90).scale(0.4),
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [6.0, 6.0, 6.0]}},
        }
    d["sensor"] = {
        "type": "perspective",
        "fov": 55,
        "to_world": T.look_at(origin=[rng.uniform(-0.5, 0.5), 1.7, 4.2], target=[0, 0.7, -1.5], up=[0, 1, 0]),
        "film": {"type": "hdrfilm", "width": WIDTH, "height": HEIGHT, "rfilter": {"type": "box"}},
        "sampler": {"type": "independent", "sample_count": 256},
    }
    return d, {"objects": n_objects, "area_light": bool(area), "surfaces": kinds}


def render(seed, out_dir, tmp):
    d, info = scene_dict(seed, tmp)
    d["integrator"] = {"type": "direct", "emitter_samples": 2, "bsdf_samples": 0}
    image = np.array(mi.render(mi.load_dict(d), spp=256))[..., :3]
    d["integrator"] = {"type": "aov", "aovs": "albedo:albedo,depth:depth"}
    aov = np.array(mi.render(mi.load_dict(d), spp=64))
    albedo, depth = aov[..., 0:3], aov[..., 3]
    if albedo.shape[-1] != 3:
        raise RuntimeError("unexpected AOV layout")
    shading = image.sum(-1) / np.maximum(albedo.sum(-1), 1e-6)
    mask = (albedo.min(-1) > 0.02) & (depth > 0)
    rel = np.zeros_like(depth)
    for axis in (0, 1):
        step = np.abs(np.diff(depth, axis=axis)) / np.maximum(depth.take(range(1, depth.shape[axis]), axis=axis), 1e-6)
        pad = [(0, 0), (0, 0)]
        pad[axis] = (0, 1)
        a = np.pad(step, pad)
        pad[axis] = (1, 0)
        b = np.pad(step, pad)
        rel = np.maximum(rel, np.maximum(a, b))
    mask &= rel < 0.05
    mask &= shading > 0
    smax = shading[mask].max()
    shading = np.where(mask, shading / smax, 0.0)
    refl = np.where(mask[..., None], albedo, 0.0)
    rmax = refl.max()
    refl = refl / rmax
    diffuse = refl * shading[..., None]
    os.makedirs(out_dir, exist_ok=True)
    save16(os.path.join(out_dir, "diffuse.png"), diffuse / diffuse.max())
    save16(os.path.join(out_dir, "reflectance.png"), refl)
    save16(os.path.join(out_dir, "shading.png"), shading)
    save16(os.path.join(out_dir, "mask.png"), mask.astype(np.float32))
    info["masked_fraction"] = float(mask.mean())
    info["seed"] = seed
    return info


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default=".cache/rendered-scenes")
    p.add_argument("--scenes", type=int, default=24)
    a = p.parse_args()
    if a.scenes < 2:
        sys.exit("--scenes: at least 2 (half tune, half test)")
    provenance = {"mitsuba": mi.__version__, "variant": mi.variant(), "width": WIDTH, "height": HEIGHT, "scenes": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(a.scenes):
            split = "tune" if seed < a.scenes // 2 else "test"
            name = f"scene{seed:02d}"
            info = render(seed, os.path.join(a.out, split, name), tmp)
            provenance["scenes"][f"{split}/{name}"] = info
            print(f"{split}/{name}: {info['objects']} objects, area light {info['area_light']}, "
                  f"{100 * info['masked_fraction']:.0f}% masked in", flush=True)
    with open(os.path.join(a.out, "provenance.json"), "w") as f:
        json.dump(provenance, f, indent=1)


if __name__ == "__main__":
    main()
