#!/usr/bin/env python3
"""Reference values for the decompose crate's LMSE and scale-invariant MSE.

Re-implements the MIT benchmark's `local_error` / `ssq_error` (Grosse et al. 2009,
intrinsic.py) with NumPy on deterministic arrays given by closed-form formulas, so the Rust
test can rebuild the same arrays without NumPy. Writes decompose/tests/data/lmse_reference.json.

Usage: python3 scripts/reference/lmse_reference.py
"""
import json
import os

import numpy as np

W, H = 47, 33


def arrays():
    y, x = np.mgrid[0:H, 0:W].astype(np.float64)
    gt = 0.2 + 0.5 * (np.sin(0.3 * x + 0.1 * y) + 1.0) / 2.0
    est = gt * (1.0 + 0.2 * np.cos(0.05 * x * y)) + 0.05 * ((x * 7 + y * 3) % 11) / 11.0
    mask = ~(((x - 20) ** 2 + (y - 15) ** 2) < 36)
    return gt, est, mask.astype(np.float64)


def ssq_error(correct, estimate, mask):
    assert correct.ndim == 2
    if np.sum(estimate ** 2 * mask) > 1e-5:
        alpha = np.sum(correct * estimate * mask) / np.sum(estimate ** 2 * mask)
    else:
        alpha = 0.0
    return np.sum(mask * (correct - alpha * estimate) ** 2)


def local_error(correct, estimate, mask, window_size, window_shift):
    M, N = correct.shape[:2]
    ssq = total = 0.0
    for i in range(0, M - window_size + 1, window_shift):
        for j in range(0, N - window_size + 1, window_shift):
            c = correct[i:i + window_size, j:j + window_size]
            e = estimate[i:i + window_size, j:j + window_size]
            m = mask[i:i + window_size, j:j + window_size]
            ssq += ssq_error(c, e, m)
            total += np.sum(m * c ** 2)
    return ssq / total


def main():
    gt, est, mask = arrays()
    out = {
        "provenance": "scripts/reference/lmse_reference.py, NumPy "
        + np.__version__
        + "; local_error/ssq_error of Grosse et al. 2009 (intrinsic.py)",
        "width": W,
        "height": H,
        "lmse_20_10": local_error(gt, est, mask, 20, 10),
        "lmse_8_4": local_error(gt, est, mask, 8, 4),
        "si_mse": ssq_error(gt, est, mask) / mask.sum(),
    }
    here = os.path.dirname(os.path.abspath(__file__))
    path = os.path.join(here, "..", "..", "decompose", "tests", "data", "lmse_reference.json")
    with open(path, "w") as f:
        json.dump(out, f, indent=2)
        f.write("\n")
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
