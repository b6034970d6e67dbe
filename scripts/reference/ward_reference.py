#!/usr/bin/env python3
"""Reference values for learner::explore::ward (learner/src/explore/ward.rs): Ward's agglomerative
clustering as computed by scipy.cluster.hierarchy.linkage(X, 'ward') (Euclidean distances,
scipy's nearest-neighbour chain), and fcluster(Z, k, 'maxclust') labels for a few k.

Writes learner/tests/data/explore/ward_reference.json with two cases:
- "fixture_standardised": the 200 fixture icons' features
  (learner/tests/data/metric/fixture-features.csv), every column standardised as
  (x - mean) / std with numpy's mean and population std (ddof=0). Columns with zero spread
  cannot be standardised and are dropped (listed under "dropped_columns"). The file stores the
  kept column names with numpy's exact means and stds, so the Rust test rebuilds bit-identical
  inputs from the CSV with one subtraction and one division per value.
- "random": 60 points in 5 dimensions, numpy.random.default_rng(20161) standard normal,
  stored as they are.

For each case the script checks that the merge heights are pairwise distinct (relative gap
above 1e-9): merge order under exact ties depends on tie-breaking and rounding, so a case with
ties would not be a fair reference. The result is recorded as "distinct_heights".

Usage (from the workspace root):  python3 scripts/reference/ward_reference.py
"""

import csv
import datetime
import json
import pathlib

import numpy as np
import scipy
from scipy.cluster.hierarchy import fcluster, linkage

ROOT = pathlib.Path(__file__).resolve().parents[2]
FEATURES = ROOT / "learner" / "tests" / "data" / "metric" / "fixture-features.csv"
OUT = ROOT / "learner" / "tests" / "data" / "explore" / "ward_reference.json"
CUTS = [1, 2, 3, 7, 20]


def fixture():
    with FEATURES.open(newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    names = header[1:]
    x = np.array([[float(v) for v in r[1:]] for r in body], dtype=np.float64)
    mean = x.mean(axis=0)
    std = x.std(axis=0)
    keep = std > 0
    dropped = [n for n, k in zip(names, keep) if not k]
    xs = (x[:, keep] - mean[keep]) / std[keep]
    case = {
        "name": "fixture_standardised",
        "source": "learner/tests/data/metric/fixture-features.csv",
        "columns": [n for n, k in zip(names, keep) if k],
        "mean": [float(v) for v in mean[keep]],
        "std": [float(v) for v in std[keep]],
        "dropped_columns": dropped,
    }
    return case, xs


def random_points():
    rng = np.random.default_rng(20161)
    x = rng.standard_normal((60, 5))
    case = {"name": "random", "points": [[float(v) for v in r] for r in x]}
    return case, x


def distinct(heights):
    h = np.sort(heights)
    gaps = np.diff(h) / np.maximum(np.abs(h[1:]), 1e-300)
    return bool(np.all(gaps > 1e-9))


def main():
    cases = []
    for case, x in [fixture(), random_points()]:
        z = linkage(x, "ward")
        case["n"] = int(x.shape[0])
        case["dim"] = int(x.shape[1])
        case["linkage"] = [[int(a), int(b), float(h), int(s)] for a, b, h, s in z]
        case["distinct_heights"] = distinct(z[:, 2])
        case["maxclust"] = {
            str(k): [int(v) for v in fcluster(z, k, "maxclust")] for k in CUTS
        }
        cases.append(case)
    out = {
        "provenance": {
            "script": "scripts/reference/ward_reference.py",
            "command": "python3 scripts/reference/ward_reference.py",
            "call": "scipy.cluster.hierarchy.linkage(X, 'ward'); fcluster(Z, k, 'maxclust')",
            "scipy": scipy.__version__,
            "numpy": np.__version__,
            "generated": datetime.date.today().isoformat(),
        },
        "cases": cases,
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {OUT.relative_to(ROOT)}")
    for c in cases:
        print(c["name"], c["n"], "x", c["dim"], "distinct heights:", c["distinct_heights"])


if __name__ == "__main__":
    main()
