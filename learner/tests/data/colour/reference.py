#!/usr/bin/env python3
"""Independent reference values for learner/src/features/colour.rs.

Computes, over the drawing region Omega of each committed rendering (*.png here, written by
the ignored Rust test `write_reference_renderings`), with numpy / scikit-image / scipy:

- HSV saturation mean and population std (skimage.color.rgb2hsv),
- entropy in bits of the 256-bin histogram of the 8-bit Rec. 601 luma
  floor((299 R + 587 G + 114 B + 500) / 1000) (scipy.stats.entropy),
- Hasler-Suesstrunk colourfulness with channels in [0, 1],
- circular std of the HSV hue over pixels with S >= 0.1, in turns (scipy.stats.circstd),

and Omega itself (non-white = some channel < 250, Euclidean dilation by 10 px via
scipy.ndimage.distance_transform_edt, holes filled with scipy.ndimage.binary_fill_holes), so
the Rust test also checks that both sides see the same region.

Usage: python3 reference.py  (rewrites reference.json next to this script)
"""

import json
import pathlib
import platform

import numpy as np
import scipy
import skimage
from scipy import ndimage, stats
from skimage import color, io

HERE = pathlib.Path(__file__).resolve().parent
FILES = [
    "fluent-emoji__fire.png",
    "twemoji__banana.png",
    "emojione-monotone__cat-face.png",
]


def omega(rgb):
    non_white = (rgb < 250).any(axis=2)
    dilated = ndimage.distance_transform_edt(~non_white) <= 10.0
    return ndimage.binary_fill_holes(dilated)


def features(rgb):
    region = omega(rgb)
    px = rgb[region].astype(np.int64)  # (n, 3) 8-bit values inside Omega
    hsv = color.rgb2hsv(rgb.astype(np.float64) / 255.0)[region]
    hue, sat = hsv[:, 0], hsv[:, 1]

    luma8 = (299 * px[:, 0] + 587 * px[:, 1] + 114 * px[:, 2] + 500) // 1000
    luma_hist = np.bincount(luma8, minlength=256)

    f = px.astype(np.float64) / 255.0
    rg = f[:, 0] - f[:, 1]
    yb = 0.5 * (f[:, 0] + f[:, 1]) - f[:, 2]
    hasler = np.hypot(rg.std(), yb.std()) + 0.3 * np.hypot(rg.mean(), yb.mean())

    chromatic = sat >= 0.1
    hue_std = (
        stats.circstd(hue[chromatic] * 2 * np.pi, high=2 * np.pi, low=0.0) / (2 * np.pi)
        if chromatic.any()
        else 0.0
    )
    return {
        "omega_count": int(region.sum()),
        "saturation_mean": float(sat.mean()),
        "saturation_std": float(sat.std()),
        "luminance_entropy": float(stats.entropy(luma_hist, base=2)),
        "hasler_colourfulness": float(hasler),
        "hue_std": float(hue_std),
    }


def main():
    icons = []
    for name in FILES:
        rgb = io.imread(HERE / name)[:, :, :3]
        icons.append({"file": name, **features(rgb)})
    out = {
        "provenance": {
            "script": "learner/tests/data/colour/reference.py",
            "python": platform.python_version(),
            "numpy": np.__version__,
            "scipy": scipy.__version__,
            "scikit-image": skimage.__version__,
            "renderings": "written by the ignored test "
            "features::colour::tests::write_reference_renderings (learner::render::render_svg)",
        },
        "icons": icons,
    }
    (HERE / "reference.json").write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()
