#!/usr/bin/env python3
"""Reference values for learner::explore::tsne (learner/src/explore/tsne/): t-SNE embeddings by
openTSNE 1.0.4 and scikit-learn 1.9.1 on the same inputs, with their quality measured by the
definitions learner::explore::tsne::quality implements.

Requires (pinned):  PIP_BREAK_SYSTEM_PACKAGES=1 python3 -m pip install --user \
    openTSNE==1.0.4 scikit-learn==1.9.1

Writes learner/tests/data/explore/tsne_reference.json with two cases:
- "blobs": 6 clusters x 100 points in 10 dimensions, numpy.random.default_rng(2016): centres
  standard normal times 4, points = centre + standard normal, rounded to float32 (the Rust side
  takes f32 rows) and stored as they are, with their cluster labels.
- "fixture_standardised": the 200 fixture icons' features
  (learner/tests/data/metric/fixture-features.csv), standardised as in ward_reference.py
  ((x - mean) / std, numpy mean and population std, zero-spread columns dropped), then rounded
  to float32. The kept columns, means and stds are stored so the Rust test rebuilds the same
  float32 rows.

For each case, at perplexity 30 and 750 iterations in all (250 of early exaggeration 12):
- openTSNE.TSNE(perplexity=30, n_iter=500, early_exaggeration_iter=250, early_exaggeration=12,
  random_state=SEED, n_jobs=1), otherwise openTSNE's defaults (PCA initialisation, learning rate
  "auto", Barnes-Hut below 10,000 points, momentum 0.8, kNN affinities over 90 neighbours);
- sklearn.manifold.TSNE(perplexity=30, max_iter=750, init="pca", learning_rate="auto",
  random_state=SEED) (Barnes-Hut, angle 0.5).
Each embedding is stored with:
- "trustworthiness": sklearn.manifold.trustworthiness(X, Y, n_neighbors=k) for k = 5, 10;
- "knn_preservation": mean over points of |kNN_X(i) & kNN_Y(i)| / k for k = 10 (Euclidean,
  self excluded, ties by lower index: a stable argsort);
- "kl_exact": KL(P || Q) with P the exact dense joint affinities of sklearn
  (sklearn.manifold._t_sne._joint_probabilities on the squared Euclidean distances, perplexity
  30) and Q the Student-t affinities of the embedding, computed as sklearn's _kl_divergence does
  (values below machine epsilon clamped to it);
- "label_purity" (blobs only): mean over points of the fraction of their 10 nearest neighbours
  in the embedding that share their label;
- openTSNE's own "kl_divergence" attribute (its kNN-based P, its gradient method's estimate).

Usage (from the workspace root):  python3 scripts/reference/tsne_reference.py
"""

import csv
import datetime
import json
import pathlib

import numpy as np
import openTSNE
import sklearn
from scipy.spatial.distance import pdist, squareform
from sklearn.manifold import TSNE, trustworthiness
from sklearn.manifold._t_sne import _joint_probabilities

ROOT = pathlib.Path(__file__).resolve().parents[2]
FEATURES = ROOT / "learner" / "tests" / "data" / "metric" / "fixture-features.csv"
OUT = ROOT / "learner" / "tests" / "data" / "explore" / "tsne_reference.json"
PERPLEXITY = 30.0
SEED = 42
MACHINE_EPSILON = np.finfo(np.double).eps


def blobs():
    rng = np.random.default_rng(2016)
    centres = rng.standard_normal((6, 10)) * 4.0
    labels = np.repeat(np.arange(6), 100)
    x = (centres[labels] + rng.standard_normal((600, 10))).astype(np.float32)
    case = {
        "name": "blobs",
        "points": [[float(v) for v in r] for r in x],
        "labels": [int(v) for v in labels],
    }
    return case, x, labels


def fixture():
    with FEATURES.open(newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    names = header[1:]
    x = np.array([[float(v) for v in r[1:]] for r in body], dtype=np.float64)
    mean = x.mean(axis=0)
    std = x.std(axis=0)
    keep = std > 0
    xs = ((x[:, keep] - mean[keep]) / std[keep]).astype(np.float32)
    case = {
        "name": "fixture_standardised",
        "source": "learner/tests/data/metric/fixture-features.csv",
        "columns": [n for n, k in zip(names, keep) if k],
        "mean": [float(v) for v in mean[keep]],
        "std": [float(v) for v in std[keep]],
    }
    return case, xs, None


def kl_exact(p, y):
    d = pdist(y.astype(np.float64), "sqeuclidean")
    w = 1.0 / (1.0 + d)
    q = np.maximum(w / (2.0 * np.sum(w)), MACHINE_EPSILON)
    return float(2.0 * np.dot(p, np.log(np.maximum(p, MACHINE_EPSILON) / q)))


def neighbours(z, k):
    d = squareform(pdist(z.astype(np.float64), "sqeuclidean"))
    np.fill_diagonal(d, np.inf)
    return np.argsort(d, axis=1, kind="stable")[:, :k]


def knn_preservation(x, y, k):
    a, b = neighbours(x, k), neighbours(y, k)
    return float(np.mean([len(set(a[i]) & set(b[i])) / k for i in range(len(x))]))


def label_purity(y, labels, k):
    nn = neighbours(y, k)
    return float(np.mean(labels[nn] == labels[:, None]))


def measure(x, y, p, labels):
    out = {
        "trustworthiness": {
            str(k): float(trustworthiness(x.astype(np.float64), y, n_neighbors=k)) for k in (5, 10)
        },
        "knn_preservation": {"10": knn_preservation(x, y, 10)},
        "kl_exact": kl_exact(p, y),
    }
    if labels is not None:
        out["label_purity"] = {"10": label_purity(y, labels, 10)}
    return out


def main():
    cases = []
    for case, x, labels in [blobs(), fixture()]:
        d = squareform(pdist(x.astype(np.float64), "sqeuclidean")).astype(np.float32)
        p = _joint_probabilities(d, PERPLEXITY, 0)
        ot = openTSNE.TSNE(
            perplexity=PERPLEXITY,
            n_iter=500,
            early_exaggeration_iter=250,
            early_exaggeration=12,
            random_state=SEED,
            n_jobs=1,
        ).fit(x.astype(np.float64))
        y_ot = np.asarray(ot)
        y_sk = TSNE(
            perplexity=PERPLEXITY,
            max_iter=750,
            init="pca",
            learning_rate="auto",
            random_state=SEED,
        ).fit_transform(x.astype(np.float64))
        case["n"] = int(x.shape[0])
        case["dim"] = int(x.shape[1])
        case["perplexity"] = PERPLEXITY
        case["opentsne"] = measure(x, y_ot, p, labels)
        case["opentsne"]["kl_divergence"] = float(ot.kl_divergence)
        case["opentsne"]["embedding"] = [[float(v) for v in r] for r in y_ot]
        case["sklearn"] = measure(x, y_sk, p, labels)
        cases.append(case)
    out = {
        "provenance": {
            "script": "scripts/reference/tsne_reference.py",
            "command": "python3 scripts/reference/tsne_reference.py",
            "opentsne": openTSNE.__version__,
            "sklearn": sklearn.__version__,
            "numpy": np.__version__,
            "seed": SEED,
            "generated": datetime.date.today().isoformat(),
        },
        "cases": cases,
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {OUT.relative_to(ROOT)}")
    for c in cases:
        for side in ("opentsne", "sklearn"):
            m = dict(c[side])
            m.pop("embedding", None)
            print(c["name"], side, m)


if __name__ == "__main__":
    main()
