"""How the pipeline's steps scale with numba's threads: fandisk's noisy mesh at one size, file to file,
each run a fresh process with ``NUMBA_NUM_THREADS`` set.

    python -m benchmarks.thread_scaling [--size 256] [--threads 1 2]

Prints each step's wall time per thread count and, from the first two counts, the share of the step
that ran in parallel (Amdahl: ``t(n) = t(1) (1 - p + p / n)``) and what that share would make of it
on 4 and 16 cores. More threads than the machine has cores share them, so only counts up to the core
count measure scaling; the projection assumes the parallel share keeps scaling, which memory bandwidth
and load balance bound (the A* searches run as many strided chunks as threads).
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
BENCH = os.path.join(HERE, "bench_pipeline.py")


def run(size, src, threads):
    env = dict(os.environ, NUMBA_NUM_THREADS=str(threads))
    out = subprocess.run([sys.executable, BENCH, "--one", str(size), src], check=True, capture_output=True,
                         text=True, env=env).stdout
    return json.loads(out.strip().splitlines()[-1])


def parallel_share(t1, t2, n2):
    """Amdahl's parallel share p from the times on 1 and on ``n2`` threads (clipped to [0, 1])."""
    if t1 <= 0:
        return 0.0
    p = (1 - t2 / t1) / (1 - 1 / n2)
    return min(max(p, 0.0), 1.0)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
    if len(args.threads) < 2 or args.threads[0] != 1:
        parser.error("--threads starts with 1 and names at least one more count")
    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "noisy.ply")
        subprocess.run([sys.executable, BENCH, "--noisy", str(args.size), src], check=True)
        run(32, src, 1)  # the numba cache, so no run pays for compilation
        results = {n: run(args.size, src, n) for n in args.threads}
    n2 = args.threads[1]
    steps = list(results[1]["steps_s"])
    head = " ".join(f"{f'{n} thr':>8}" for n in args.threads)
    print(f"fandisk at {args.size}, {os.cpu_count()} cores; seconds per step")
    print(f"{'step':40s} {head} {'parallel':>9} {'4 cores':>8} {'16 cores':>9}")
    rows = [(name, [results[n]["steps_s"].get(name, 0.0) for n in args.threads]) for name in steps]
    rows.append(("total, mesh file to mesh file", [results[n]["total_s"] for n in args.threads]))
    for name, times in rows:
        p = parallel_share(times[0], times[1], n2)
        projected = [times[0] * (1 - p + p / n) for n in (4, 16)]
        cells = " ".join(f"{t:8.2f}" for t in times)
        print(f"{name:40s} {cells} {p:9.0%} {projected[0]:8.2f} {projected[1]:9.2f}")


if __name__ == "__main__":
    main()
