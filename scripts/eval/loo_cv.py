#!/usr/bin/env python3
"""Leave-one-scene-out cross-validation over a grid of `decompose eval-lightfield --json` runs.

Usage: loo_cv.py RUN.json [RUN.json ...]   (one file per parameter setting, same scenes)

For every held-out scene, the setting with the lowest mean LMSE over the other scenes is chosen
and scored on the held-out scene. Prints the chosen setting per fold, the cross-validated mean
LMSE and incoherence, and the in-sample best for comparison.
"""
import json
import sys
from pathlib import Path


def load(path):
    data = json.loads(Path(path).read_text())
    scores = {}
    for scene, methods in data.items():
        row = methods["ours"]["scores"]
        scores[scene] = (row["lmse"], row["incoherence"])
    return scores


def main():
    runs = {Path(p).stem: load(p) for p in sys.argv[1:]}
    scenes = sorted(next(iter(runs.values())))
    for name, s in runs.items():
        if sorted(s) != scenes:
            sys.exit(f"{name}: scenes {sorted(s)} differ from {scenes}")
    mean = lambda xs: sum(xs) / len(xs)
    held = []
    for out in scenes:
        train = [s for s in scenes if s != out]
        best = min(runs, key=lambda r: mean([runs[r][s][0] for s in train]))
        held.append(runs[best][out])
        print(f"held out {out}: chose {best:<24} LMSE {runs[best][out][0]:.4f}  "
              f"incoherence {runs[best][out][1]:.5f}")
    print(f"cross-validated mean: LMSE {mean([h[0] for h in held]):.4f}  "
          f"incoherence {mean([h[1] for h in held]):.5f}")
    best = min(runs, key=lambda r: mean([runs[r][s][0] for s in scenes]))
    print(f"in-sample best {best}: LMSE {mean([runs[best][s][0] for s in scenes]):.4f}  "
          f"incoherence {mean([runs[best][s][1] for s in scenes]):.5f}")


if __name__ == "__main__":
    main()
