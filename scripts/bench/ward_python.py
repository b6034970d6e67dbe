#!/usr/bin/env python3
"""The Python side of `learner bench ward`: times scipy.cluster.hierarchy.linkage(X, 'ward') on
the points `learner bench ward` wrote (raw little-endian f64, row-major) and prints one JSON line
{"seconds": best of the runs, "scipy": version, "heights_sum": sum of the merge heights}.

Usage: python3 scripts/bench/ward_python.py POINTS.f64 DIM RUNS
"""

import json
import sys
import time

import numpy as np
import scipy
from scipy.cluster.hierarchy import linkage


def main():
    path, dim, runs = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    x = np.fromfile(path, dtype="<f8").reshape(-1, dim)
    best = float("inf")
    for _ in range(runs):
        start = time.perf_counter()
        z = linkage(x, "ward")
        best = min(best, time.perf_counter() - start)
    print(json.dumps({"seconds": best, "scipy": scipy.__version__, "heights_sum": float(z[:, 2].sum())}))


if __name__ == "__main__":
    main()
