#!/usr/bin/env python3
"""The exact style query of `learner bench search`, done the way a Python user would: numpy
(`argpartition` over the pre-scaled matrix) and, if importable, faiss `IndexFlatL2`.

Usage: search_numpy.py DIR --k 50 [--direct 30]

DIR holds what the bench wrote: `matrix.f32` (items x stride, little-endian float32: each item's
sqrt(w) * standardised features, zero-padded), `queries.f32` (queries x stride, the same
projection of each query drawing), `ours.json` ({"n", "stride", "k", "rows": [[top-k rows of
each query], ...]}). Prints one JSON object on stdout: per engine the latencies (ms, one query
at a time, one thread) and the mean share of our top-k each engine also returns.

Run with OMP_NUM_THREADS=OPENBLAS_NUM_THREADS=MKL_NUM_THREADS=1 (the bench sets them) so the
comparison is one core against one core.
"""

import argparse
import json
import os
import sys
import time

for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

try:
    import numpy as np
except ImportError as e:  # the bench prints the reason in its table
    json.dump({k: {"skipped": f"numpy not importable ({e})"}
               for k in ("numpy_gemv", "numpy_direct", "faiss_flat_l2")}
              | {"versions": {"python": sys.version.split()[0]}}, sys.stdout)
    sys.exit(0)


def percentiles(ms):
    ms = np.sort(np.asarray(ms))
    return {
        "p50": float(np.percentile(ms, 50)),
        "p99": float(np.percentile(ms, 99)),
        "mean": float(ms.mean()),
        "queries": int(len(ms)),
    }


def agreement(found, ours, k):
    return float(np.mean([len(set(map(int, f)) & set(o)) / k for f, o in zip(found, ours)]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dir")
    ap.add_argument("--k", type=int, default=50)
    ap.add_argument("--direct", type=int, default=30, help="queries for the (x - q)^2 variant")
    a = ap.parse_args()
    meta = json.load(open(os.path.join(a.dir, "ours.json")))
    n, stride, k = meta["n"], meta["stride"], a.k
    X = np.fromfile(os.path.join(a.dir, "matrix.f32"), dtype="<f4").reshape(n, stride)
    Q = np.fromfile(os.path.join(a.dir, "queries.f32"), dtype="<f4").reshape(-1, stride)
    ours = meta["rows"]
    out = {"versions": {"python": sys.version.split()[0], "numpy": np.__version__}}

    # 1. The usual numpy route: ||x||^2 - 2 x.q + ||q||^2 with a BLAS matrix-vector product.
    norms = np.einsum("ij,ij->i", X, X)
    found, ms = [], []
    for q in Q:
        t = time.perf_counter()
        d = norms - 2.0 * (X @ q) + q @ q
        idx = np.argpartition(d, k)[:k]
        idx = idx[np.argsort(d[idx], kind="stable")]
        ms.append((time.perf_counter() - t) * 1e3)
        found.append(idx)
    out["numpy_gemv"] = percentiles(ms) | {"agreement": agreement(found, ours, k)}

    # 2. The literal one: sum of squared differences (a temporary the size of the matrix).
    found, ms = [], []
    for q in Q[: a.direct]:
        t = time.perf_counter()
        diff = X - q
        d = np.einsum("ij,ij->i", diff, diff)
        idx = np.argpartition(d, k)[:k]
        idx = idx[np.argsort(d[idx], kind="stable")]
        ms.append((time.perf_counter() - t) * 1e3)
        found.append(idx)
    out["numpy_direct"] = percentiles(ms) | {"agreement": agreement(found, ours[: a.direct], k)}

    try:
        import faiss

        faiss.omp_set_num_threads(1)
        index = faiss.IndexFlatL2(stride)
        index.add(np.ascontiguousarray(X))
        found, ms = [], []
        for q in Q:
            t = time.perf_counter()
            _, idx = index.search(q[None, :], k)
            ms.append((time.perf_counter() - t) * 1e3)
            found.append(idx[0])
        out["faiss_flat_l2"] = percentiles(ms) | {"agreement": agreement(found, ours, k)}
        out["versions"]["faiss"] = faiss.__version__
    except ImportError as e:
        out["faiss_flat_l2"] = {"skipped": str(e)}

    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
