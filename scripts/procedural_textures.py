"""Procedural printed textures shared by the renderers of intrinsic ground truth
(`render_intrinsic_scenes.py`, `render_lightfields.py`): generated, so they carry no licence
question, and seeded through the caller's numpy Generator, so every scene is reproducible.

Each function takes a `numpy.random.Generator` and returns a linear float RGB image in [0, 1]
of `size × size` pixels.
"""

import numpy as np


def paper_with_ink(rng, size=256):
    """Text-like marks and pen lines on coloured paper."""
    paper = rng.uniform(0.75, 0.95, 3) * np.array([1.0, rng.uniform(0.9, 1.0), rng.uniform(0.8, 1.0)])
    img = np.ones((size, size, 3)) * paper
    ink = rng.choice([np.array([0.05, 0.05, 0.06]), np.array([0.1, 0.15, 0.5]), np.array([0.5, 0.08, 0.08])])
    for row in range(12, size - 12, 18):
        x = 10
        while x < size - 20:
            wlen = int(rng.integers(4, 22))
            h = int(rng.integers(5, 9))
            img[row : row + h, x : x + wlen] = ink
            x += wlen + int(rng.integers(4, 8))
    for _ in range(int(rng.integers(1, 4))):
        y = int(rng.integers(0, size))
        img[y : y + 2, :] = ink
    return img


def stripes(rng, size=256):
    a, b = rng.uniform(0.05, 0.9, 3), rng.uniform(0.05, 0.9, 3)
    period = int(rng.integers(12, 48))
    x = np.arange(size)
    band = ((x // (period // 2)) % 2).astype(bool)
    img = np.where(band[None, :, None], a, b) * np.ones((size, size, 3))
    return img if rng.random() < 0.5 else img.transpose(1, 0, 2)


def checks(rng, size=256):
    a, b = rng.uniform(0.05, 0.9, 3), rng.uniform(0.05, 0.9, 3)
    n = int(rng.integers(4, 12))
    y, x = np.mgrid[0:size, 0:size] * n // size
    return np.where(((x + y) % 2 == 0)[..., None], a, b)


def dots(rng, size=256):
    bg, fg = rng.uniform(0.3, 0.9, 3), rng.uniform(0.03, 0.7, 3)
    img = np.ones((size, size, 3)) * bg
    y, x = np.mgrid[0:size, 0:size]
    step = int(rng.integers(24, 48))
    r = step * rng.uniform(0.2, 0.35)
    cy, cx = (y % step) - step / 2, (x % step) - step / 2
    img[(cy * cy + cx * cx) < r * r] = fg
    return img


def patches(rng, size=256):
    img = np.ones((size, size, 3)) * rng.uniform(0.5, 0.9, 3)
    for _ in range(int(rng.integers(4, 9))):
        y0, x0 = rng.integers(0, size - 40, 2)
        h, w = rng.integers(30, 120, 2)
        img[y0 : y0 + h, x0 : x0 + w] = rng.uniform(0.03, 0.9, 3)
    return img


TEXTURES = [paper_with_ink, stripes, checks, dots, patches]
