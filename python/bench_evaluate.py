"""gonio.evaluate on numpy arrays (degrees, broadcast, NaN checks) against the C++ batch
evaluation timed in C++ (gonio.bench_batch): time per value and their ratio (docs/python.md).

Usage: PYTHONPATH=build/python python3 python/bench_evaluate.py [N] [MODEL...]
One thread on both sides (GONIO_BENCH_THREADS=0 for all cores), interleaved, best of 15 rounds.
"""
import os
import sys
import time

import numpy as np

import gonio

n = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
models = sys.argv[2:] or ["lambert", "oren-nayar", "oren-nayar-fujii", "tson"]
threads = int(os.environ.get("GONIO_BENCH_THREADS", "1"))
rounds = int(os.environ.get("GONIO_BENCH_ROUNDS", "15"))
rng = np.random.default_rng(0)
ti, tr, phi = rng.uniform(0, 85, n), rng.uniform(0, 85, n), rng.uniform(0, 180, n)
print(f"{'model':<24} {'numpy ns/value':>15} {'C++ ns/value':>13} {'ratio':>6}")
rad = np.radians(ti), np.radians(tr), np.radians(phi)
for model in models:
    # Interleaved, best of each: both sides see the same load.
    best, cpp = float("inf"), float("inf")
    for _ in range(rounds):
        t0 = time.perf_counter()
        gonio.evaluate(model, {}, ti, tr, phi, threads=threads)
        best = min(best, time.perf_counter() - t0)
        cpp = min(cpp, gonio.bench_batch(model, {}, *rad, 1, threads))
    print(f"{model:<24} {1e9 * best / n:15.2f} {cpp:13.2f} {1e9 * best / n / cpp:6.2f}")
