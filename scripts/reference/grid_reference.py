#!/usr/bin/env python3
"""Reference values for learner::explore::grid (learner/src/explore/grid/): the exact linear
assignment, Spearman's rank correlation and Isomap's classical MDS, computed by scipy and numpy.

Writes learner/tests/data/explore/grid_reference.json with:
- "lap": seeded random cost matrices (numpy.random.default_rng(2016)), square and rectangular
  (rows <= columns), real-valued and small integers (many ties), and the optimal total of
  scipy.optimize.linear_sum_assignment with the column of each row (under ties the optimal
  assignment is not unique: the Rust test compares totals, and columns only where
  "unique" is true, checked here by re-solving with the optimum's cells forbidden one at a time).
- "spearman": samples with ties and scipy.stats.spearmanr's correlation.
- "isomap": 80 points on a noisy 2-D sheet rolled in 3-D, stored as float32 values; the symmetric
  k-nearest-neighbour graph (k = 6, Euclidean, an edge when either end is among the other's k
  nearest), geodesics by scipy.sparse.csgraph.shortest_path (Dijkstra), then classical MDS by
  numpy.linalg.eigh of B = -1/2 J D^2 J: the top two eigenvalues and eigenvectors, each vector's
  sign fixed so that its largest-magnitude entry is positive.

Usage (from the workspace root):  python3 scripts/reference/grid_reference.py
"""

import datetime
import json
import pathlib

import numpy as np
import scipy
from scipy.optimize import linear_sum_assignment
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import shortest_path
from scipy.stats import spearmanr

ROOT = pathlib.Path(__file__).resolve().parents[2]
OUT = ROOT / "learner" / "tests" / "data" / "explore" / "grid_reference.json"


def unique_optimum(c, rows, cols, total):
    """True when every other assignment costs more (forbid each chosen cell in turn)."""
    for r, k in zip(rows, cols):
        d = c.copy()
        d[r, k] = 1e12
        rr, cc = linear_sum_assignment(d)
        if d[rr, cc].sum() <= total + 1e-9 * max(1.0, abs(total)):
            return False
    return True


def lap_cases(rng):
    cases = []
    for name, n, m, integer in [
        ("square_6", 6, 6, False),
        ("rect_5x9", 5, 9, False),
        ("square_40_int", 40, 40, True),
        ("rect_30x60_int", 30, 60, True),
        ("square_100", 100, 100, False),
        ("rect_80x140", 80, 140, False),
    ]:
        if integer:
            c = rng.integers(0, 20, size=(n, m)).astype(np.float64)
        else:
            c = rng.uniform(-10.0, 10.0, size=(n, m))
        rows, cols = linear_sum_assignment(c)
        total = float(c[rows, cols].sum())
        cases.append(
            {
                "name": name,
                "rows": n,
                "cols": m,
                "cost": c.ravel().tolist(),
                "total": total,
                "col": cols.tolist(),
                "unique": bool(unique_optimum(c, rows, cols, total)),
            }
        )
    return cases


def spearman_cases(rng):
    out = []
    for name, a, b in [
        ("continuous", rng.normal(size=200), None),
        ("ties", rng.integers(0, 5, size=300).astype(float), None),
    ]:
        b = a * 0.5 + rng.normal(size=a.size) if b is None else b
        if name == "ties":
            b = np.round(b)
        rho = spearmanr(a, b).statistic
        out.append({"name": name, "a": a.tolist(), "b": b.tolist(), "rho": float(rho)})
    return out


def isomap_case(rng):
    n, k = 80, 6
    t = rng.uniform(1.5 * np.pi, 4.0 * np.pi, size=n)
    h = rng.uniform(0.0, 8.0, size=n)
    x = np.stack([t * np.cos(t), h, t * np.sin(t)], axis=1) + rng.normal(scale=0.05, size=(n, 3))
    x = x.astype(np.float32).astype(np.float64)
    d = np.sqrt(((x[:, None, :] - x[None, :, :]) ** 2).sum(-1))
    w = np.zeros((n, n))
    for i in range(n):
        order = np.argsort(d[i], kind="stable")
        nn = [j for j in order if j != i][:k]
        for j in nn:
            w[i, j] = d[i, j]
            w[j, i] = d[i, j]
    g = shortest_path(csr_matrix(w), method="D", directed=False)
    assert np.isfinite(g).all(), "the reference graph must be connected"
    j = np.eye(n) - 1.0 / n
    b = -0.5 * j @ (g**2) @ j
    vals, vecs = np.linalg.eigh(b)
    order = np.argsort(vals)[::-1][:2]
    out_vecs = []
    for o in order:
        v = vecs[:, o]
        if v[np.argmax(np.abs(v))] < 0:
            v = -v
        out_vecs.append(v.tolist())
    return {
        "k": k,
        "points": x.tolist(),
        "eigenvalues": [float(vals[o]) for o in order],
        "third_eigenvalue": float(np.sort(vals)[::-1][2]),
        "eigenvectors": out_vecs,
        "geodesic_sum": float(g.sum()),
    }


def main():
    rng = np.random.default_rng(2016)
    data = {
        "provenance": {
            "script": "scripts/reference/grid_reference.py",
            "scipy": scipy.__version__,
            "numpy": np.__version__,
            "seed": 2016,
            "generated": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%MZ"),
        },
        "lap": lap_cases(rng),
        "spearman": spearman_cases(rng),
        "isomap": isomap_case(rng),
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(data) + "\n")
    print(f"wrote {OUT.relative_to(ROOT)}")
    for c in data["lap"]:
        print(c["name"], c["total"], "unique" if c["unique"] else "ties")


if __name__ == "__main__":
    main()
