#!/usr/bin/env python3
"""The same 169-feature pipeline written the way a Python user would: numpy, scipy.ndimage,
scikit-image and mahotas. Used by `learner bench features --python` to time our Rust features side by
side with the libraries a user would otherwise pick. It is a timing reference, not a numeric
one (the numeric references for the texture features live in scripts/reference/).

Usage: features_python.py DIR_OF_400x400_PNGS --json OUT.json
Writes {"images": N, "seconds_per_image": {"prepare": s, "colour": s, ...}, "versions": {...}}.
"""
import argparse
import glob
import json
import os
import time

import mahotas
import numpy as np
import scipy
import skimage
from scipy import ndimage as ndi
from skimage import color, feature, filters, io, morphology, transform


def prepare(rgb):
    f = rgb.astype(np.float64) / 255.0
    non_white = np.any(rgb < 250, axis=2)
    region = ndi.binary_fill_holes(ndi.binary_dilation(non_white, structure=morphology.disk(10)))
    silhouette = ndi.binary_fill_holes(non_white)
    grey = color.rgb2gray(f)
    edges = feature.canny(grey, sigma=1.0, low_threshold=0.1, high_threshold=0.2)
    return f, region, silhouette, grey, edges


def colour_features(f, region):
    hsv = color.rgb2hsv(f)[region]
    h, s, v = hsv[:, 0], hsv[:, 1], hsv[:, 2]
    lum = color.rgb2gray(f)[region]
    out = [np.std(h[s >= 0.1]) if np.any(s >= 0.1) else 0.0, s.mean(), s.std(), lum.mean(), lum.std()]
    hist = np.histogram(lum, 256, (0, 1))[0] / lum.size
    out.append(-np.sum(hist[hist > 0] * np.log2(hist[hist > 0])))
    q = (f[region] * 7.999).astype(int)
    codes = q[:, 0] * 64 + q[:, 1] * 8 + q[:, 2]
    rgbh = np.bincount(codes, minlength=512) / codes.size
    out.append(-np.sum(rgbh[rgbh > 0] * np.log2(rgbh[rgbh > 0])))
    r, g, b = f[region].T
    rg, yb = r - g, 0.5 * (r + g) - b
    out.append(np.sqrt(rg.var() + yb.var()) + 0.3 * np.sqrt(rg.mean() ** 2 + yb.mean() ** 2))
    out.append(np.mean(np.abs(r - g) + np.abs(g - b) + np.abs(b - r)))
    out.append(np.mean(v <= 0.2))
    out.append(rgbh.max())
    hh = np.histogram(h[s >= 0.1], 20, (0, 1))[0]
    out += [hh.max() / max(1, hh.sum()), np.sum(hh > 0.05 * max(1, hh.max()))]
    out += [rgbh.max(), np.sum(rgbh > 0.05 * rgbh.max())]
    return out


def shading_features(f, region):
    out = []
    for scale in (1, 2):
        img = transform.downscale_local_mean(f, (scale, scale, 1)) if scale > 1 else f
        reg = region[::scale, ::scale][: img.shape[0], : img.shape[1]]
        mag = np.sqrt(sum(filters.sobel_h(img[..., c]) ** 2 + filters.sobel_v(img[..., c]) ** 2 for c in range(3)))
        black = img.max(axis=2) <= 0.2
        phi = reg & ~black & (mag > 0)
        n = max(1, reg.sum())
        out += list(np.histogram(np.minimum(mag[phi], 1.1), 8, (0, 1.1))[0] / n)
        out += list(np.histogram(mag[reg & black], 8, (0, 2.5))[0] / n)
    return out


def lbp_features(grey, region, silhouette, edges):
    g8 = np.round(grey * 255).astype(np.uint8)
    contour = silhouette & ~ndi.binary_erosion(silhouette)
    out = []
    for where in (edges & region, contour):
        for p, r in ((8, 1), (12, 2), (16, 4)):
            codes = feature.local_binary_pattern(g8, p, r, method="uniform")[where]
            hist = np.bincount(codes.astype(int), minlength=p + 2)
            out += list(hist / max(1, hist.sum()))
    return out


def glcm_features(grey, region):
    levels = (np.round(grey * 255).astype(np.uint8) // 32).astype(np.uint8)
    levels[~region] = 0
    har = mahotas.features.haralick(levels, return_mean=True)
    m = feature.graycomatrix(levels, [1], [0, np.pi / 4, np.pi / 2, 3 * np.pi / 4], levels=8, symmetric=True, normed=True)
    extra = [feature.graycoprops(m, p).mean() for p in ("dissimilarity", "homogeneity", "energy", "correlation")]
    return list(har) + extra


def swt_widths(grey, edges):
    gy, gx = np.gradient(ndi.gaussian_filter(grey, 1.0))
    h, w = grey.shape
    widths = []
    ys, xs = np.nonzero(edges)
    for y, x in zip(ys, xs):
        mag = np.hypot(gx[y, x], gy[y, x])
        if mag == 0:
            continue
        dx, dy = -gx[y, x] / mag, -gy[y, x] / mag
        for step in range(1, 100):
            cx, cy = int(round(x + dx * step)), int(round(y + dy * step))
            if not (0 <= cx < w and 0 <= cy < h):
                break
            if edges[cy, cx] and (cx, cy) != (x, y):
                m2 = np.hypot(gx[cy, cx], gy[cy, cx])
                if m2 > 0 and (gx[cy, cx] * dx + gy[cy, cx] * dy) / m2 > np.cos(np.pi / 6):
                    widths.append(step)
                break
    return widths


def stroke_features(grey, silhouette):
    out = []
    for k in range(4):
        g = transform.downscale_local_mean(grey, (2**k, 2**k)) if k else grey
        e = feature.canny(g, sigma=1.0, low_threshold=0.1, high_threshold=0.2)
        widths = swt_widths(g, e)
        for part in (widths[: len(widths) // 2], widths[len(widths) // 2 :]):
            out += [np.mean(part) if part else 0.0, np.std(part) if part else 0.0]
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("folder")
    ap.add_argument("--json", required=True)
    args = ap.parse_args()
    paths = sorted(glob.glob(os.path.join(args.folder, "*.png")))
    totals = dict(prepare=0.0, colour=0.0, shading=0.0, lbp=0.0, glcm=0.0, swt=0.0)
    for path in paths:
        rgb = io.imread(path)[..., :3]
        t = time.perf_counter()
        f, region, silhouette, grey, edges = prepare(rgb)
        t1 = time.perf_counter(); colour_features(f, region)
        t2 = time.perf_counter(); shading_features(f, region)
        t3 = time.perf_counter(); lbp_features(grey, region, silhouette, edges)
        t4 = time.perf_counter(); glcm_features(grey, region)
        t5 = time.perf_counter(); stroke_features(grey, silhouette)
        t6 = time.perf_counter()
        for key, dt in zip(totals, (t1 - t, t2 - t1, t3 - t2, t4 - t3, t5 - t4, t6 - t5)):
            totals[key] += dt
    n = max(1, len(paths))
    result = {
        "images": len(paths),
        "seconds_per_image": {k: v / n for k, v in totals.items()},
        "versions": {"numpy": np.__version__, "scipy": scipy.__version__, "scikit-image": skimage.__version__, "mahotas": mahotas.__version__},
    }
    with open(args.json, "w") as fh:
        json.dump(result, fh, indent=2)


if __name__ == "__main__":
    main()
