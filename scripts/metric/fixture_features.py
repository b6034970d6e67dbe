#!/usr/bin/env python3
"""Snapshot the 169 features of the 200 fixture icons for the solver-agreement test.

Copies the rows of fixtures/style/labels.csv's ids out of a features CSV written by
`learner features` over the dev set (default .cache/dev-features.csv) into
learner/tests/data/metric/fixture-features.csv, and writes 1,000 labelled-group triplets over
them (same generator as `learner triplets`, seed 7) to fixture-triplets.csv with the release
binary. The feature values are a snapshot: re-run when the extractor changes.

Usage (repository root): python3 scripts/metric/fixture_features.py [FEATURES] [LEARNER_BIN]
"""
import csv
import subprocess
import sys

src = sys.argv[1] if len(sys.argv) > 1 else ".cache/dev-features.csv"
binary = sys.argv[2] if len(sys.argv) > 2 else "target/release/learner"
ids = [r["file"] for r in csv.DictReader(open("fixtures/style/labels.csv"))]
want = set(ids)
out = "learner/tests/data/metric/fixture-features.csv"
with open(src) as f, open(out, "w", newline="") as g:
    r = csv.reader(f)
    w = csv.writer(g)
    w.writerow(next(r))
    n = 0
    for row in r:
        if row[0] in want:
            w.writerow(row)
            n += 1
print(f"{out}: {n} of {len(ids)} fixture icons")
subprocess.run([binary, "triplets", "--labels", "fixtures/style/labels.csv", "--features", out,
                "--n", "1000", "--seed", "7",
                "--out", "learner/tests/data/metric/fixture-triplets.csv"], check=True)
