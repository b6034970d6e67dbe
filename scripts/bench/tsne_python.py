#!/usr/bin/env python3
"""The Python side of `learner bench tsne`: openTSNE (pinned 1.0.4; see
scripts/reference/tsne_reference.py for the install line) on the points `learner bench tsne`
wrote (raw little-endian f32, row-major), with the same perplexity, iterations, exaggeration and
seed. Writes the embedding (little-endian f32, n x 2) to OUT and prints one JSON line:
{"seconds": wall time of fit, "cpu_seconds": user + system time of fit (all threads), "kl_divergence": openTSNE's own, "method": the negative-gradient
method, "maxrss_kb": peak resident size of this process (VmHWM of /proc/self/status, KB: the
getrusage figure would carry over the forking Rust process's peak across exec),
"opentsne": version}.

Usage: python3 scripts/bench/tsne_python.py POINTS.f32 DIM OUT.f32 PERPLEXITY N_ITER EE_ITER
       EARLY_EXAGGERATION N_JOBS SEED METHOD
METHOD is openTSNE's negative_gradient_method: auto (Barnes-Hut below 10,000 points, FFT
interpolation above), bh or fft.
"""

import json
import resource
import sys
import time

import numpy as np
import openTSNE


def peak_rss_kb():
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def main():
    path, dim, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    perplexity, n_iter, ee_iter = float(sys.argv[4]), int(sys.argv[5]), int(sys.argv[6])
    exaggeration, n_jobs, seed, method = float(sys.argv[7]), int(sys.argv[8]), int(sys.argv[9]), sys.argv[10]
    x = np.fromfile(path, dtype="<f4").reshape(-1, dim).astype(np.float64)
    n = x.shape[0]
    resolved = method if method != "auto" else ("bh" if n < 10_000 else "fft")
    usage = resource.getrusage(resource.RUSAGE_SELF)
    cpu = usage.ru_utime + usage.ru_stime
    start = time.perf_counter()
    y = openTSNE.TSNE(
        perplexity=perplexity,
        n_iter=n_iter - ee_iter,
        early_exaggeration_iter=ee_iter,
        early_exaggeration=exaggeration,
        n_jobs=n_jobs,
        random_state=seed,
        negative_gradient_method=resolved,
    ).fit(x)
    seconds = time.perf_counter() - start
    usage = resource.getrusage(resource.RUSAGE_SELF)
    cpu = usage.ru_utime + usage.ru_stime - cpu
    np.asarray(y, dtype="<f4").tofile(out)
    print(
        json.dumps(
            {
                "seconds": seconds,
                "cpu_seconds": cpu,
                "kl_divergence": float(y.kl_divergence),
                "method": resolved,
                "maxrss_kb": peak_rss_kb(),
                "opentsne": openTSNE.__version__,
            }
        )
    )


if __name__ == "__main__":
    main()
