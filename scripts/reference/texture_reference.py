#!/usr/bin/env python3
"""Reference values for the texture features (learner/src/features/{lbp,glcm}.rs).

Reads the 8-bit grey renderings in learner/tests/data/texture/*_grey.png (exported by
`REGENERATE=1 cargo test -p learner --lib features::lbp::tests::regenerate_reference_inputs`)
and writes, next to them:

- `<name>_lbp_p<P>r<R>.png`: scikit-image's `local_binary_pattern(grey, P, R, 'uniform')`
  (riu2) code of every pixel, as an 8-bit PNG (codes 0..P+1);
- `reference.json`: provenance, the ring offsets scikit-image uses, the interior code
  histograms, and GLCM statistics from scikit-image (`graycomatrix`/`graycoprops`) and mahotas
  (`features.haralick`) on the whole image quantised to 8 levels (`g >> 5`), distance 1, the
  four directions 0/45/90/135 degrees, symmetric, averaged over the directions.

Conventions converted here so that the values are comparable with ours (see glcm.rs):
- mahotas' entropies use log2; ours use ln: sum entropy, entropy and difference entropy are
  multiplied by ln 2; IMC2 is recomputed per direction from mahotas' value m as
  sqrt(1 - (1 - m^2)^(ln 2)) (mahotas: m = sqrt(1 - exp(-2 dH_bits)); ours:
  sqrt(1 - exp(-2 dH_nats)), dH_nats = dH_bits ln 2) and then averaged; IMC1 is a ratio of
  entropies and needs no conversion.
- mahotas' difference variance is taken with use_x_minus_y_variance=True (the variance of
  |i - j|, our definition).
- scikit-image's 'energy' is sqrt(ASM); we compare our energy (= ASM) with its 'ASM'.

Usage (from the workspace root):  python3 scripts/reference/texture_reference.py
"""

import datetime
import json
import math
import pathlib
import sys

import mahotas
import numpy as np
import skimage
from skimage.feature import graycomatrix, graycoprops, local_binary_pattern
from skimage.io import imread, imsave

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "learner" / "tests" / "data" / "texture"
IMAGES = [
    ("noto_dog_face", "fixtures/style/noto/dog-face.svg"),
    ("emojione_bicycle", "fixtures/style/emojione-monotone/bicycle.svg"),
    ("fluent_house", "fixtures/style/fluent-emoji/house.svg"),
]
SCALES = [(8, 1), (12, 2), (16, 4)]
LEVELS = 8


def ring_offsets(P, R):
    """The offsets scikit-image's _local_binary_pattern uses (for the record)."""
    k = np.arange(P, dtype=np.float64)
    rr = -R * np.sin(2 * np.pi * k / P)
    cc = R * np.cos(2 * np.pi * k / P)
    return np.round(rr, 5).tolist(), np.round(cc, 5).tolist()


def lbp_reference(name, grey):
    out = []
    for P, R in SCALES:
        codes = local_binary_pattern(grey, P, R, method="uniform")
        assert np.all(codes == np.round(codes)) and codes.min() >= 0 and codes.max() <= P + 1
        codes = codes.astype(np.uint8)
        png = f"{name}_lbp_p{P}r{R}.png"
        imsave(DATA / png, codes, check_contrast=False)
        assert np.array_equal(imread(DATA / png), codes)
        m = int(math.ceil(R))
        interior = codes[m:-m, m:-m]
        rows, cols = ring_offsets(P, R)
        out.append(
            {
                "P": P,
                "R": float(R),
                "codes_png": png,
                "row_offsets": rows,
                "col_offsets": cols,
                "interior_margin": m,
                "interior_histogram": np.bincount(interior.ravel(), minlength=P + 2).tolist(),
            }
        )
    return out


def skimage_glcm(levels):
    angles = [0, np.pi / 4, np.pi / 2, 3 * np.pi / 4]
    g = graycomatrix(levels, [1], angles, levels=LEVELS, symmetric=True, normed=True)
    mean = lambda prop: float(graycoprops(g, prop).mean())  # noqa: E731
    return {
        "contrast": mean("contrast"),
        "dissimilarity": mean("dissimilarity"),
        "homogeneity_haralick": mean("homogeneity"),  # sum p / (1 + (i-j)^2)
        "energy": mean("ASM"),  # our energy is the ASM
        "correlation_matlab": mean("correlation"),
        "correlation_haralick": mean("correlation"),
    }


def mahotas_glcm(levels):
    per_dir = mahotas.features.haralick(levels, use_x_minus_y_variance=True, distance=1)
    assert per_dir.shape == (4, 13)
    ln2 = math.log(2.0)
    imc2 = np.sqrt(np.maximum(0.0, 1.0 - (1.0 - per_dir[:, 12] ** 2) ** ln2))
    mean = per_dir.mean(axis=0)
    # Cross-check: return_mean=True is the plain mean over directions.
    assert np.allclose(
        mean,
        mahotas.features.haralick(
            levels, use_x_minus_y_variance=True, distance=1, return_mean=True
        ),
        rtol=0,
        atol=0,
    )
    return {
        "energy": float(mean[0]),  # ASM
        "contrast": float(mean[1]),
        "correlation_haralick": float(mean[2]),
        "sum_of_squares_variance": float(mean[3]),
        "homogeneity_haralick": float(mean[4]),  # IDM
        "sum_average": float(mean[5]),
        "sum_variance": float(mean[6]),
        "sum_entropy": float(mean[7]) * ln2,
        "entropy": float(mean[8]) * ln2,
        "difference_variance": float(mean[9]),
        "difference_entropy": float(mean[10]) * ln2,
        "imc1": float(mean[11]),
        "imc2": float(imc2.mean()),
    }


def main():
    images = []
    for name, svg in IMAGES:
        png = f"{name}_grey.png"
        grey = imread(DATA / png)
        assert grey.dtype == np.uint8 and grey.ndim == 2, (png, grey.dtype, grey.shape)
        levels = grey >> 5
        images.append(
            {
                "name": name,
                "source_svg": svg,
                "grey_png": png,
                "shape": list(grey.shape),
                "lbp": lbp_reference(name, grey),
                "glcm_levels": LEVELS,
                "glcm": {"skimage": skimage_glcm(levels), "mahotas": mahotas_glcm(levels)},
            }
        )
    reference = {
        "provenance": {
            "script": "scripts/reference/texture_reference.py",
            "command": "python3 scripts/reference/texture_reference.py",
            "date": datetime.date.today().isoformat(),
            "python": sys.version.split()[0],
            "numpy": np.__version__,
            "scikit-image": skimage.__version__,
            "mahotas": mahotas.__version__,
            "inputs": "8-bit grey round(255 * Rec.601 luma) of learner::render::render_svg, "
            "exported by REGENERATE=1 cargo test -p learner --lib "
            "features::lbp::tests::regenerate_reference_inputs",
            "lbp": "skimage.feature.local_binary_pattern(grey_u8, P, R, method='uniform'); "
            "code maps in <name>_lbp_p<P>r<R>.png (zero padding at the border, so only pixels "
            "at least ceil(R) from the border are comparable)",
            "glcm": "levels = grey >> 5 (8 levels), whole image, distance 1, angles 0/45/90/135, "
            "symmetric, mean over the 4 directions; mahotas entropies converted from log2 to "
            "ln, IMC2 recomputed per direction in nats, difference variance with "
            "use_x_minus_y_variance=True; skimage 'ASM' compared with our energy",
        },
        "glcm_relative_tolerance": 1e-9,
        "images": images,
    }
    with open(DATA / "reference.json", "w") as f:
        json.dump(reference, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
