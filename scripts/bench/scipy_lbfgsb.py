#!/usr/bin/env python3
"""Time SciPy's L-BFGS-B on the metric objective exported by `learner bench metric`.

Usage: scipy_lbfgsb.py DIR   (DIR holds problem.json, x.f64, w0.f64, triplets.u32)
Prints one JSON object: seconds, objective, evaluations, iterations, message, numpy_eval_seconds.

The objective is identical to learner::metric::objective (eq. 5.8 of Garces et al. 2014 with the
smoothed root): E(w) = sum_i softplus(-s_i (d_ac - d_ab)) + lambda * sum(w), d = sqrt(w.delta^2 + eps),
s_i = +1 when q = 1 else -1, bounds w >= 0. The squared differences are precomputed outside the
timed region (the fairest setup for NumPy: each evaluation is then two matrix-vector products).
SciPy runs with its defaults (ftol = 2.2e-9, gtol = 1e-5, m = 10), which the Rust bench mirrors.
"""
import json
import sys
import time

import numpy as np
from scipy.optimize import minimize


def main() -> None:
    d = sys.argv[1]
    meta = json.load(open(f"{d}/problem.json"))
    rows, dim, lam, eps = meta["rows"], meta["dim"], meta["lambda"], meta["smoothing"]
    x = np.fromfile(f"{d}/x.f64", dtype="<f8").reshape(rows, dim)
    w0 = np.fromfile(f"{d}/w0.f64", dtype="<f8")
    t = np.fromfile(f"{d}/triplets.u32", dtype="<u4").reshape(-1, 4).astype(np.int64)
    a, b, c, q = t[:, 0], t[:, 1], t[:, 2], t[:, 3]
    dab2 = (x[a] - x[b]) ** 2
    dac2 = (x[a] - x[c]) ** 2
    sign = np.where(q == 1, 1.0, -1.0)

    def fun(w):
        dab = np.sqrt(np.maximum(dab2 @ w, 0.0) + eps)
        dac = np.sqrt(np.maximum(dac2 @ w, 0.0) + eps)
        z = sign * (dac - dab)
        loss = np.logaddexp(0.0, -z).sum()
        dz = -0.5 * (1.0 - np.tanh(0.5 * z))  # -sigma(-z), stable
        dm = sign * dz
        grad = dac2.T @ (dm / (2.0 * dac)) - dab2.T @ (dm / (2.0 * dab)) + lam
        return loss + lam * w.sum(), grad

    t0 = time.perf_counter()
    for _ in range(5):
        fun(w0)
    one = (time.perf_counter() - t0) / 5
    t0 = time.perf_counter()
    res = minimize(fun, w0, jac=True, method="L-BFGS-B", bounds=[(0.0, None)] * dim)
    secs = time.perf_counter() - t0
    print(json.dumps({
        "seconds": secs,
        "objective": float(res.fun),
        "evaluations": int(res.nfev),
        "iterations": int(res.nit),
        "message": str(res.message),
        "numpy_eval_seconds": one,
    }))


if __name__ == "__main__":
    main()
