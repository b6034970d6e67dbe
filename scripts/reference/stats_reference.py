#!/usr/bin/env python3
"""Reference values for learner::stats (learner/src/stats/): the one-sample one-sided t-test, the
mean's t confidence interval, Cohen's d, and the Student t distribution's sf/cdf/ppf.

Writes fixtures/stats/ttest_reference.json with, per sample set:
- scipy.stats.ttest_1samp(x, 0.5, alternative='greater'): statistic, df, pvalue;
- the two-sided 95% interval scipy.stats.t.interval(0.95, n - 1, loc=mean, scale=sem(x));
- Cohen's d for one sample, (mean - 0.5) / std(x, ddof=1);
and a grid of scipy.stats.t.sf / t.cdf / t.ppf values, including extreme tails.

The sample sets cover what the platform's studies produce: per-worker preference rates
(fractions of 8-20 answers, with ties), n = 2, a sample below chance, a strongly significant one
(p ~ 1e-20) and mean list positions of the mash-up study (not rates: only the interval is used).

Usage (from the workspace root):  python3 scripts/reference/stats_reference.py
"""

import datetime
import json
import pathlib

import numpy as np
import scipy
import scipy.stats as st

ROOT = pathlib.Path(__file__).resolve().parents[2]
OUT = ROOT / "fixtures" / "stats" / "ttest_reference.json"


def samples():
    rng = np.random.default_rng(20141121)
    sets = {
        "n2": [0.75, 0.5],
        "n2_wide": [1.0, 0.125],
        "ties_eighths": [0.625, 0.75, 0.625, 0.5, 0.875, 0.625, 0.75, 0.75],
        "paper_like_coherence": list(
            np.round(rng.binomial(12, 0.68, size=20) / 12, 12)
        ),
        "paper_like_preference": list(
            np.round(rng.binomial(10, 0.64, size=35) / 10, 12)
        ),
        "below_chance": [0.4, 0.3, 0.55, 0.45, 0.35, 0.5],
        "near_chance": [0.5, 0.55, 0.45, 0.5, 0.6, 0.4, 0.5, 0.52],
        "extreme_p": list(0.9 + rng.normal(0.0, 0.01, size=40)),
        "huge_t_small_n": [0.99, 0.991, 0.992],
        "positions_metric": list(rng.integers(1, 60, size=16).astype(float)),
        "positions_random": list(rng.integers(1, 96, size=14).astype(float)),
    }
    return {k: [float(v) for v in x] for k, x in sets.items()}


def main():
    out = {
        "provenance": {
            "script": "scripts/reference/stats_reference.py",
            "scipy": scipy.__version__,
            "numpy": np.__version__,
            "generated": datetime.date.today().isoformat(),
            "mu0": 0.5,
            "alternative": "greater",
            "confidence": 0.95,
        },
        "samples": [],
        "distribution": [],
    }
    for name, x in samples().items():
        a = np.array(x)
        n = len(a)
        res = st.ttest_1samp(a, 0.5, alternative="greater")
        mean = float(np.mean(a))
        sd = float(np.std(a, ddof=1))
        low, high = st.t.interval(0.95, n - 1, loc=mean, scale=st.sem(a))
        out["samples"].append(
            {
                "name": name,
                "x": x,
                "mean": mean,
                "sd": sd,
                "t": float(res.statistic),
                "df": float(res.df),
                "p": float(res.pvalue),
                "effect_size": (mean - 0.5) / sd,
                "ci_low": float(low),
                "ci_high": float(high),
            }
        )
    for df in [1.0, 2.0, 3.0, 4.5, 7.0, 19.0, 34.0, 120.0, 1000.0]:
        for t in [-40.0, -3.2, -1.0, -1e-3, 0.0, 0.3, 1.7, 2.5, 6.0, 25.0, 150.0]:
            out["distribution"].append(
                {
                    "df": df,
                    "t": t,
                    "sf": float(st.t.sf(t, df)),
                    "cdf": float(st.t.cdf(t, df)),
                }
            )
        for p in [1e-15, 1e-6, 0.005, 0.025, 0.1, 0.4, 0.6, 0.95, 0.975, 0.995]:
            out["distribution"].append({"df": df, "p": p, "ppf": float(st.t.ppf(p, df))})
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
