"""Per-step time and peak memory of the pipeline on fandisk, mesh file to mesh file; and the
commands a user runs first: a clean mesh, an everyday scan, a volume, the import.

    python -m benchmarks.bench_pipeline [--sizes 128 192 256 384] [--with-512] [--json out.json]
                                        [--volume-size 256] [--everyday-mesh PATH] [--no-commands]
                                        [--repeat 3]

Each size runs in its own process, which only reads the noisy mesh, denoises it and
writes the result (numba kernels load from the on-disk cache, so compilation is not
timed; the noisy mesh is made beforehand by another process). The JSON also holds
each step's CPU time (all threads), which tells how much of a step's wall time on a
shared machine was spent waiting. Peak memory is the
process' resident peak (VmHWM, everything included): it is read at the end of every
step and then reset through /proc/self/clear_refs, so a step's peak also covers the
work between it and the previous step. In the same process, after the pipeline, one
``scipy.ndimage.distance_transform_edt(return_indices=True)`` on the same padded grid
is timed: the ratio of the pipeline to it holds on a loaded machine where seconds don't.
The exponent of each step is the slope of log(time) against log(grid voxels) over the
sizes run.

The commands (each a fresh ``skelfilter denoise IN OUT`` process with no flags, wall time, best
of ``--repeat``, three by default): the bundled Stanford bunny, clean (69 451 faces), against
reading and writing it in a fresh process (the floor: the interpreter, trimesh and the file); an
everyday scan, the bunny with Gaussian noise of 0.2 mean edge lengths along its normals as the
literature's Bunny0.2 (or the mesh ``--everyday-mesh`` names); ``python -c "import skelfilter"``;
``skelfilter --help``. ``--targets`` prints issue 50's limits against these figures.
The volume: fandisk's voxelization at ``--volume-size`` with the thesis' stripes, through
``denoise_volume``, against one scipy EDT of it.
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

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SAMPLE = os.path.join(HERE, "..", "skelfilter", "data", "fandisk.obj")
BUNNY = os.path.join(HERE, "..", "skelfilter", "data", "stanford-bunny.obj")
MIB = 2**20


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


def make_noisy(size, path, seed=1):
    """Fandisk voxelized at ``size`` with the thesis' stripes, as a mesh file."""
    from skelfilter.io import mesh_files
    from skelfilter.mesh import pipeline as mesh_pipeline
    from skelfilter.params import NoiseParams

    noisy, _, _ = mesh_pipeline.noisy_mesh(mesh_files.load_mesh(SAMPLE), NoiseParams(resolution=size, seed=seed))
    mesh_files.save_mesh(noisy, path)


def run_one(size, src):
    """Denoise the mesh file ``src`` at ``size``, file to file; then time the reference EDT."""
    from scipy import ndimage

    from skelfilter.io import mesh_files
    from skelfilter.mesh import pipeline as mesh_pipeline
    from skelfilter.mesh import voxelize
    from skelfilter.params import DenoiseParams
    from skelfilter.runtime.progress import Progress

    class Probe(Progress):
        def __init__(self):
            super().__init__(enabled=False)
            self.memory = {}
            self.cpu = {}

        @contextmanager
        def step(self, name):
            cpu = time.process_time()
            with super().step(name):
                yield
            key = self._prefix + name
            self.cpu[key] = self.cpu.get(key, 0.0) + time.process_time() - cpu
            self.memory[key] = max(self.memory.get(key, 0.0), _peak_rss_mib())
            _reset_peak()

    params = DenoiseParams(resolution=size)
    probe = Probe()
    with tempfile.TemporaryDirectory() as tmp:
        dst = os.path.join(tmp, "denoised.ply")
        _reset_peak()
        start = time.perf_counter()
        with probe.step("read"):
            mesh = mesh_files.load_mesh(src)
        out, result, grid = mesh_pipeline.denoise_mesh_detailed(mesh, params, probe)
        with probe.step("write"):
            mesh_files.save_mesh(out, dst)
        total = time.perf_counter() - start
    peak = max(probe.memory.values())
    stages = {}
    for name, stage in result.stages.items():
        s = stage.skeleton
        searched = s.expansions[s.expansions > 0] if s.expansions is not None else np.zeros(0)
        stages[name] = {
            "skeleton_voxels": int(len(s.voxels)),
            "kept": int(s.kept.sum()),
            "astar_searches": int(len(searched)),
            "astar_expansions_mean": float(searched.mean()) if len(searched) else 0.0,
        }
    del out, result
    occupancy = voxelize.voxelize_on_grid(mesh, grid)
    start = time.perf_counter()
    ndimage.distance_transform_edt(occupancy, return_indices=True)
    edt = time.perf_counter() - start
    return {
        "size": size,
        "grid": list(grid.shape),
        "voxels": int(grid.n_voxels),
        "total_s": total,
        "edt_with_indices_s": edt,
        "edt_ratio": total / edt,
        "peak_rss_mib": peak,
        "bytes_per_voxel": peak * MIB / grid.n_voxels,
        "steps_s": probe.timings,
        "steps_cpu_s": probe.cpu,
        "steps_peak_mib": probe.memory,
        "stages": stages,
    }


def run_volume(size):
    """The noisy voxelization of fandisk at ``size`` through `denoise_volume`; then the reference EDT."""
    from scipy import ndimage

    from skelfilter.core.pipeline import denoise_volume
    from skelfilter.io import mesh_files
    from skelfilter.mesh import pipeline as mesh_pipeline
    from skelfilter.params import NoiseParams

    _, masks, _ = mesh_pipeline.noisy_mesh(mesh_files.load_mesh(SAMPLE), NoiseParams(resolution=size, seed=1))
    volume = masks.noisy
    del masks
    start = time.perf_counter()
    denoise_volume(volume)
    total = time.perf_counter() - start
    start = time.perf_counter()
    ndimage.distance_transform_edt(volume, return_indices=True)
    edt = time.perf_counter() - start
    return {"size": size, "voxels": int(volume.size), "total_s": total, "edt_with_indices_s": edt,
            "edt_ratio": total / edt}


def make_everyday(path):
    """The bundled bunny with the literature's scanner noise: Gaussian offsets along the vertex
    normals, 0.2 mean edge lengths (Bunny0.2's level), fixed seed."""
    from skelfilter.io import mesh_files

    mesh = mesh_files.load_mesh(BUNNY)
    sigma = 0.2 * float(mesh.edges_unique_length.mean())
    offsets = np.random.default_rng(0).normal(0.0, sigma, len(mesh.vertices))
    mesh.vertices = mesh.vertices + mesh.vertex_normals * offsets[:, None]
    mesh_files.save_mesh(mesh, path)


def _wall(args, repeat=3):
    """Best wall time of ``repeat`` fresh processes running ``args`` (which must succeed)."""
    best = float("inf")
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run(args, check=True, capture_output=True)
        best = min(best, time.perf_counter() - start)
    return best


def commands(tmp, everyday_mesh=None, repeat=3):
    """Seconds of the first commands a user runs (see the module's docstring), best of ``repeat``."""
    everyday = everyday_mesh or os.path.join(tmp, "bunny-noisy-0.2.ply")
    if everyday_mesh is None:
        make_everyday(everyday)
    out = os.path.join(tmp, "out.ply")
    denoise = [sys.executable, "-m", "skelfilter.cli", "denoise", "--quiet"]
    floor = [sys.executable, "-c", "import sys; from skelfilter.io import mesh_files; "
             "mesh_files.save_mesh(mesh_files.load_mesh(sys.argv[1]), sys.argv[2])", BUNNY, out]
    _wall(denoise + [BUNNY, out], repeat=1)  # the numba cache of the mesh path's kernels
    return {
        "clean_s": _wall(denoise + [BUNNY, out], repeat),
        "read_write_s": _wall(floor, repeat),
        "everyday_s": _wall(denoise + [everyday, out], repeat),
        "everyday_mesh": everyday_mesh or "the bundled bunny with 0.2 mean edge lengths of normal noise",
        "import_s": _wall([sys.executable, "-c", "import skelfilter"], repeat),
        "help_s": _wall([sys.executable, "-m", "skelfilter.cli", "--help"], repeat),
    }


def exponents(results):
    """Slope of log(time) against log(voxels) per step and for the total (None below 2 sizes)."""
    if len(results) < 2:
        return {}
    x = np.log([r["voxels"] for r in results])
    fits = {}
    for step in results[0]["steps_s"]:
        t = np.array([max(r["steps_s"].get(step, 0.0), 1e-4) for r in results])
        fits[step] = float(np.polyfit(x, np.log(t), 1)[0])
    fits["total"] = float(np.polyfit(x, np.log([r["total_s"] for r in results]), 1)[0])
    fits["edt_with_indices"] = float(np.polyfit(x, np.log([r["edt_with_indices_s"] for r in results]), 1)[0])
    return fits


def targets(results, fits, volume=None, runs=None):
    """The project's targets that this run can check: name -> (measured, limit, met)."""
    by_size = {r["size"]: r for r in results}
    checks = {}
    if 256 in by_size:
        checks["total / EDT at 256"] = by_size[256]["edt_ratio"], 2.0
        importance = by_size[256]["steps_s"].get("foreground/importance", 0.0)
        checks["importance / EDT at 256"] = importance / by_size[256]["edt_with_indices_s"], 1.0
    within = [r for r in results if 128 <= r["size"] <= 384]
    if len(within) >= 3:
        local = exponents(within)
        step, worst = max(((k, v) for k, v in local.items() if k != "edt_with_indices"), key=lambda kv: kv[1])
        checks[f"largest exponent over 128-384 ({step})"] = worst, 1.1
    if 512 in by_size:
        checks["peak memory at 512 (GiB)"] = by_size[512]["peak_rss_mib"] / 1024, 3.0
    if volume is not None:
        checks[f"volume total / EDT at {volume['size']}"] = volume["edt_ratio"], 4.0
    if runs is not None:
        checks["clean bunny, seconds over read+write + 1 s"] = runs["clean_s"] - runs["read_write_s"] - 1.0, 0.0
        checks["everyday scan (s)"] = runs["everyday_s"], 1.6
        checks["skelfilter --help (s)"] = runs["help_s"], 0.3
        checks["import skelfilter (s)"] = runs["import_s"], 0.4
    return {name: (value, limit, bool(value <= limit)) for name, (value, limit) in checks.items()}


def _child(*args):
    out = subprocess.run([sys.executable, __file__, *map(str, args)], check=True, capture_output=True, text=True)
    return out.stdout.strip().splitlines()[-1] if out.stdout.strip() else ""


def machine():
    """A one-line description of the machine and its load when the run started."""
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {
        "processor": platform.processor() or platform.machine(),
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "load_average_1min": load[0],
    }


def print_table(results, fits, info, volume=None, runs=None, with_targets=False):
    print(f"machine: {info['processor']}, {info['cores']} cores, python {info['python']}, "
          f"load average {info['load_average_1min']:.2f} at start")
    cols = "".join(f"{r['size']:>10d}³" for r in results)
    print(f"{'step (seconds)':40s}{cols}  exponent")

    def row(label, values, fmt, fit=None):
        tail = f"  {fit:8.2f}" if fit is not None else ""
        print(f"{label:40s}" + "".join(format(v, fmt) for v in values) + tail)

    for step in results[0]["steps_s"]:
        row(step, [r["steps_s"].get(step, 0.0) for r in results], "11.2f", fits.get(step))
    row("total, mesh file to mesh file", [r["total_s"] for r in results], "11.2f", fits.get("total"))
    row("scipy EDT with indices, same grid", [r["edt_with_indices_s"] for r in results], "11.2f",
        fits.get("edt_with_indices"))
    row("ratio total / EDT", [r["edt_ratio"] for r in results], "11.2f")
    row("peak resident memory (MiB)", [r["peak_rss_mib"] for r in results], "11.0f")
    row("bytes per grid voxel", [r["bytes_per_voxel"] for r in results], "11.1f")
    row("grid voxels (millions)", [r["voxels"] / 1e6 for r in results], "11.2f")
    for stage in ("foreground", "background"):
        row(f"{stage} skeleton voxels", [r["stages"].get(stage, {}).get("skeleton_voxels", 0) for r in results],
            "11d")
        row(f"{stage} A* nodes per search",
            [r["stages"].get(stage, {}).get("astar_expansions_mean", 0.0) for r in results], "11.1f")
    print("step with the highest peak: " + "; ".join(
        f"{r['size']}: {max(r['steps_peak_mib'], key=r['steps_peak_mib'].get)}" for r in results))
    if volume is not None:
        print(f"volume (fandisk's noisy voxels at {volume['size']}, {volume['voxels'] / 1e6:.1f} M voxels): "
              f"{volume['total_s']:.2f} s, one scipy EDT {volume['edt_with_indices_s']:.2f} s, "
              f"ratio {volume['edt_ratio']:.2f}")
    if runs is not None:
        print(f"skelfilter denoise, no flags, fresh process: clean bunny {runs['clean_s']:.2f} s "
              f"(reading + writing it {runs['read_write_s']:.2f} s); everyday scan {runs['everyday_s']:.2f} s "
              f"({runs['everyday_mesh']}); import skelfilter {runs['import_s']:.2f} s; "
              f"skelfilter --help {runs['help_s']:.2f} s")
    if with_targets:
        for name, (value, limit, met) in targets(results, fits, volume, runs).items():
            print(f"target {name}: {value:.2f} (limit {limit:g}): {'within' if met else 'over'}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sizes", type=int, nargs="+", default=[128, 192, 256, 384])
    parser.add_argument("--with-512", action="store_true", help="also run 512 (about 150 M voxels)")
    parser.add_argument("--json", help="also write the results as JSON here")
    parser.add_argument("--volume-size", type=int, default=256, help="the volume's grid (0: no volume)")
    parser.add_argument("--everyday-mesh", help="the everyday scan to time (default: the bunny with noise)")
    parser.add_argument("--no-commands", action="store_true", help="skip the clean, everyday and import runs")
    parser.add_argument("--repeat", type=int, default=3, help="fresh processes per command (the best counts)")
    parser.add_argument("--targets", action="store_true",
                        help="also print the project's time and memory targets against these figures")
    parser.add_argument("--volume", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--noisy", nargs=2, help=argparse.SUPPRESS)
    parser.add_argument("--one", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.noisy:
        make_noisy(int(args.noisy[0]), args.noisy[1])
        return 0
    if args.one:
        print(json.dumps(run_one(int(args.one[0]), args.one[1])))
        return 0
    if args.volume:
        print(json.dumps(run_volume(args.volume)))
        return 0
    sizes = args.sizes + ([512] if args.with_512 else [])
    info = machine()
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        # Warm the numba cache once so no size pays for compilation.
        warm = os.path.join(tmp, "warm.ply")
        _child("--noisy", 32, warm)
        _child("--one", 32, warm)
        for size in sizes:
            src = os.path.join(tmp, f"noisy-{size}.ply")
            _child("--noisy", size, src)
            results.append(json.loads(_child("--one", size, src)))
            print(f"  {size}: {results[-1]['total_s']:.1f} s", file=sys.stderr)
        volume = json.loads(_child("--volume", args.volume_size)) if args.volume_size else None
        runs = None if args.no_commands else commands(tmp, args.everyday_mesh, args.repeat)
    fits = exponents(results)
    print_table(results, fits, info, volume, runs, args.targets)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"machine": info, "results": results, "exponents": fits, "volume": volume, "commands": runs,
                       "targets": targets(results, fits, volume, runs)}, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
