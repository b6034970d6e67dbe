#!/usr/bin/env python3
"""The Python side of `learner bench grid`: times scipy.optimize.linear_sum_assignment on the cost
matrix `learner bench grid` wrote (raw little-endian f64, row-major ROWS x COLS) and prints one
JSON line {"seconds": best of the runs, "scipy": version, "total": optimal total cost}.

Usage: python3 scripts/bench/lap_python.py COST.f64 ROWS COLS RUNS
"""

import json
import sys
import time

import numpy as np
import scipy
from scipy.optimize import linear_sum_assignment


def main():
    path, rows, cols, runs = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    c = np.fromfile(path, dtype="<f8").reshape(rows, cols)
    best = float("inf")
    for _ in range(runs):
        start = time.perf_counter()
        r, k = linear_sum_assignment(c)
        best = min(best, time.perf_counter() - start)
    print(json.dumps({"seconds": best, "scipy": scipy.__version__, "total": float(c[r, k].sum())}))


if __name__ == "__main__":
    main()
