"""Per-stage time and peak memory of the pipeline on fandisk, mesh file to mesh file.

    python benchmarks/bench_pipeline.py [--sizes 128 192 256] [--json out.json]

Each size runs in its own process (numba kernels load from the on-disk cache,
so compilation is not timed). Peak memory per step is the process' resident
peak (VmHWM), reset before every step through /proc/self/clear_refs.
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLE = os.path.join(HERE, "..", "skelfilter", "data", "fandisk.obj")


def _peak_rss_mib():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def _reset_peak():
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
    except OSError:  # no clear_refs (non-Linux): the peak then covers the whole run so far
        return


def run_one(size, seed=1):
    """Noise fandisk at ``size``, write it, then time denoising file to file."""
    from skelfilter import io, pipeline
    from skelfilter.params import DenoiseParams, NoiseParams
    from skelfilter.progress import Progress

    class Probe(Progress):
        def __init__(self):
            super().__init__(enabled=False)
            self.memory = {}

        @contextmanager
        def step(self, name):
            _reset_peak()
            with super().step(name):
                yield
            key = self._prefix + name
            self.memory[key] = max(self.memory.get(key, 0.0), _peak_rss_mib())

    clean = io.load_mesh(SAMPLE)
    noisy, _, _ = pipeline.noisy_mesh(clean, NoiseParams(resolution=size, seed=seed))
    with tempfile.TemporaryDirectory() as tmp:
        src, dst = os.path.join(tmp, "noisy.ply"), os.path.join(tmp, "denoised.ply")
        io.save_mesh(noisy, src)
        probe = Probe()
        start = time.perf_counter()
        with probe.step("read"):
            mesh = io.load_mesh(src)
        out, result, grid = pipeline.denoise_mesh_detailed(mesh, DenoiseParams(resolution=size), probe)
        with probe.step("write"):
            io.save_mesh(out, dst)
        total = time.perf_counter() - start
    stages = {}
    for name, stage in result.stages.items():
        s = stage.skeleton
        expansions = s.expansions[s.expansions > 0] if s.expansions is not None else []
        stages[name] = {
            "skeleton_voxels": int(len(s.voxels)),
            "kept": int(s.kept.sum()),
            "astar_expansions_mean": float(expansions.mean()) if len(expansions) else 0.0,
        }
    return {
        "size": size,
        "grid": list(grid.shape),
        "voxels": int(grid.n_voxels),
        "total_s": total,
        "peak_rss_mib": max(probe.memory.values()),
        "steps_s": probe.timings,
        "steps_peak_mib": probe.memory,
        "stages": stages,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[128, 192, 256])
    parser.add_argument("--json", help="also write the results as JSON here")
    parser.add_argument("--one", type=int, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one:
        print(json.dumps(run_one(args.one)))
        return 0
    # Warm the numba cache once so no size pays for compilation.
    subprocess.run([sys.executable, __file__, "--one", "32"], check=True, capture_output=True)
    results = []
    for size in args.sizes:
        out = subprocess.run([sys.executable, __file__, "--one", str(size)], check=True, capture_output=True,
                             text=True)
        results.append(json.loads(out.stdout.strip().splitlines()[-1]))
    steps = list(results[0]["steps_s"])
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, python "
          f"{platform.python_version()}")
    header = f"{'step':38s}" + "".join(f"{r['size']:>9d}³ s" for r in results)
    print(header)
    for step in steps:
        print(f"{step:38s}" + "".join(f"{r['steps_s'].get(step, 0):11.2f}" for r in results))
    print(f"{'total (file to file)':38s}" + "".join(f"{r['total_s']:11.2f}" for r in results))
    print(f"{'peak resident memory (MiB)':38s}" + "".join(f"{r['peak_rss_mib']:11.0f}" for r in results))
    print(f"{'grid voxels (millions)':38s}" + "".join(f"{r['voxels'] / 1e6:11.1f}" for r in results))
    for stage in ("foreground", "background"):
        print(f"{stage + ' skeleton voxels':38s}" + "".join(
            f"{r['stages'].get(stage, {}).get('skeleton_voxels', 0):11d}" for r in results))
        print(f"{stage + ' A* nodes per search':38s}" + "".join(
            f"{r['stages'].get(stage, {}).get('astar_expansions_mean', 0):11.1f}" for r in results))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
