"""Many files: ``skelfilter batch`` on a local Dask cluster against one file after another in one process.

    python -m benchmarks.batch [--files 40] [--resolution 128] [--workers 1 2 4]

Makes ``--files`` noisy meshes (the embedded fandisk with the thesis' stripes, one seed each), then
denoises them (1) one after another in this process, numba on every core, and (2) with
`skelfilter.jobs.batch.denoise_many` on a LocalCluster of each ``--workers`` count in turn (default:
the machine's cores); prints the wall times, files per minute and the speed-up of each. A worker is
one process; numba's threads in each share the cores, so more workers than cores shows what the
cluster's overhead costs, not what more machines would give.
"""

import argparse
import os
import tempfile
import time

from skelfilter.io import mesh_files as io
from skelfilter.io.samples import sample_path
from skelfilter.jobs import batch
from skelfilter.jobs import denoise_file as files
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.params import DenoiseParams, NoiseParams


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", type=int, default=40)
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--workers", type=int, nargs="+", default=[None],
                        help="worker processes of each cluster timed (default: one per core)")
    args = parser.parse_args()
    clean = io.load_mesh(sample_path())
    with tempfile.TemporaryDirectory() as work:
        inputs = os.path.join(work, "in")
        os.makedirs(inputs)
        for seed in range(args.files):
            noisy = mesh_pipeline.noisy_mesh(clean, NoiseParams(resolution=args.resolution, seed=seed))[0]
            io.save_mesh(noisy, os.path.join(inputs, f"fandisk-{seed:03d}.ply"))
        params = DenoiseParams(resolution=args.resolution)
        start = time.perf_counter()
        for name in sorted(os.listdir(inputs)):
            files.denoise_file(os.path.join(inputs, name), os.path.join(work, "serial-" + name), params)
        serial = time.perf_counter() - start
        timed = []
        for workers in args.workers:
            start = time.perf_counter()
            rows = batch.denoise_many([inputs], os.path.join(work, f"batch-{workers}"), workers=workers,
                                      resolution=args.resolution)
            timed.append((workers or os.cpu_count(), time.perf_counter() - start,
                          sum(row["status"] != "ok" for row in rows)))
    print(f"{args.files} meshes at resolution {args.resolution} on {os.cpu_count()} cores: one after another "
          f"{serial:.1f} s ({60 * args.files / serial:.1f} files per minute)")
    for workers, seconds, failed in timed:
        print(f"  batch on a local cluster of {workers} workers: {seconds:.1f} s (cluster start included), "
              f"{60 * args.files / seconds:.1f} files per minute, speed-up {serial / seconds:.2f}x; {failed} failed")


if __name__ == "__main__":
    main()
