#!/usr/bin/env python3
"""Reference retrieval metrics from scikit-learn for learner::eval::rank.

Writes learner/tests/data/metric/rank_reference.json: small seeded point sets with class labels
and, averaged over every item as a query (the others ranked by increasing Euclidean distance,
relevant = same class), AUC (sklearn.metrics.roc_auc_score), MAP (average_precision_score),
NDCG@3/@10 (ndcg_score with k), plus MRR and Prec@3/@10 computed with NumPy (sklearn has no
MRR or precision-at-k for a single ranking). Queries without a relevant or an irrelevant item are
skipped, as in the Rust code. Continuous random points make distance ties impossible in practice.

Run from the repository root: python3 scripts/metric/rank_reference.py
"""
import json

import numpy as np
import sklearn
from sklearn.metrics import average_precision_score, ndcg_score, roc_auc_score


def case(seed, n, dim, classes):
    rng = np.random.default_rng(seed)
    labels = rng.integers(0, classes, size=n)
    # Class-dependent means so rankings are informative but imperfect.
    y = rng.normal(size=(n, dim)) + 0.8 * labels[:, None] * rng.normal(size=(1, dim))
    rows = []
    for q in range(n):
        others = np.array([j for j in range(n) if j != q])
        d = ((y[others] - y[q]) ** 2).sum(axis=1)
        rel = (labels[others] == labels[q]).astype(int)
        if rel.sum() == 0 or rel.sum() == len(rel):
            continue
        order = np.argsort(d)
        r = rel[order]
        first = int(np.argmax(r == 1))
        rows.append([
            roc_auc_score(rel, -d),
            average_precision_score(rel, -d),
            1.0 / (first + 1),
            r[:3].sum() / 3.0,
            r[:10].sum() / 10.0,
            ndcg_score([rel], [-d], k=3),
            ndcg_score([rel], [-d], k=10),
        ])
    m = np.array(rows).mean(axis=0)
    keys = ["auc", "map", "mrr", "prec_at_3", "prec_at_10", "ndcg_at_3", "ndcg_at_10"]
    return {
        "seed": seed,
        "dim": dim,
        "points": y.ravel().tolist(),
        "labels": labels.tolist(),
        "queries": len(rows),
        "expected": dict(zip(keys, m.tolist())),
    }


def main():
    out = {
        "provenance": f"scripts/metric/rank_reference.py with scikit-learn {sklearn.__version__}, "
        f"numpy {np.__version__}",
        "cases": [case(1, 25, 3, 3), case(2, 40, 5, 4), case(3, 12, 2, 2)],
    }
    path = "learner/tests/data/metric/rank_reference.json"
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    print(path)


if __name__ == "__main__":
    main()
