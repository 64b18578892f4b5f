"""Point clouds: skelfilter's surface of a noisy cloud against screened Poisson reconstruction
(open3d's and MeshLab's), scored against the clean mesh the cloud was sampled from.

    python -m benchmarks.point_clouds [--shapes fandisk,rocker-arm,spot,bunny] [--points 30000]
                                      [--noise 0.004] [--out cloud-output]

Each clean mesh is sampled uniformly by area (``--points`` points, no normals) and each point moved by
Gaussian noise of ``--noise`` times the bounding box's diagonal along each axis. Methods:

- ``open3d poisson``: open3d's screened Poisson of the points, normals estimated from 50 neighbours
  and oriented consistently, octree depth from the points' spacing (skelfilter's own first step,
  `skelfilter.mesh.point_cloud.points_to_mesh`);
- ``meshlab poisson``: MeshLab's screened Poisson (``generate_surface_reconstruction_screened_poisson``
  at its defaults, depth 8) after ``compute_normal_for_point_clouds`` (10 neighbours, smoothed);
- ``skelfilter``: ``skelfilter denoise cloud.xyz out.ply``, no flags.

Scores: ``chamfer`` (the mean of the mean distances both ways, % of the diagonal) and ``normal_error``
(degrees, area-weighted, against the closest clean face; `skelfilter.evaluation.metrics`). CAD shapes
(fandisk, rocker arm) and organic ones (spot the cow, the bunny). Writes ``results.json`` and
``table.md`` into ``--out``.
"""

import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np
import trimesh

from benchmarks import shapes
from skelfilter.evaluation.metrics.mesh_metrics import normal_error
from skelfilter.mesh.closest_points import MeshSurface

SHAPES = ("fandisk", "rocker-arm", "spot", "bunny")


def noisy_cloud(mesh, count, noise, seed):
    points, _ = trimesh.sample.sample_surface(mesh, count, seed=seed)
    diagonal = float(np.linalg.norm(np.ptp(mesh.bounds, axis=0)))
    return points + np.random.default_rng(seed).normal(0.0, noise * diagonal, points.shape)


def open3d_poisson(points, folder):
    from skelfilter.io.point_files import load_points
    from skelfilter.mesh.point_cloud import points_to_mesh

    path = os.path.join(folder, "cloud.xyz")
    np.savetxt(path, points)
    return points_to_mesh(load_points(path))


def meshlab_poisson(points, folder):
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=points))
    ms.compute_normal_for_point_clouds()
    ms.generate_surface_reconstruction_screened_poisson()
    out = ms.current_mesh()
    return trimesh.Trimesh(out.vertex_matrix(), out.face_matrix(), process=True)


def skelfilter_cli(points, folder):
    from skelfilter.jobs.denoise_file import denoise_file
    from skelfilter.params import DenoiseParams

    path, out = os.path.join(folder, "cloud.xyz"), os.path.join(folder, "out.ply")
    np.savetxt(path, points)
    denoise_file(path, out, DenoiseParams())
    return trimesh.load(out, process=False)


METHODS = {"open3d poisson": open3d_poisson, "meshlab poisson": meshlab_poisson, "skelfilter": skelfilter_cli}


def chamfer_percent(mesh, clean, samples=30_000):
    diagonal = float(np.linalg.norm(np.ptp(clean.bounds, axis=0)))
    a, _ = trimesh.sample.sample_surface(mesh, samples, seed=2)
    b, _ = trimesh.sample.sample_surface(clean, samples, seed=3)
    there = MeshSurface(clean).distance(a).mean()
    back = MeshSurface(mesh).distance(b).mean()
    return float(100 * (there + back) / 2 / diagonal)


def run_case(shape, count, noise, seed=1):
    clean = shapes.load(shape)
    points = noisy_cloud(clean, count, noise, seed)
    row = {"shape": shape, "points": count, "noise": noise, "methods": {}}
    for name, method in METHODS.items():
        start = time.perf_counter()
        with tempfile.TemporaryDirectory() as folder:
            try:
                mesh = method(points, folder)
            except Exception as exc:  # a method under test: record it, measure the rest
                row["methods"][name] = {"error": f"{type(exc).__name__}: {exc}"}
                continue
        row["methods"][name] = {"chamfer": chamfer_percent(mesh, clean), "normal_error": normal_error(mesh, clean),
                                "seconds": time.perf_counter() - start}
    return row


def table(rows):
    methods = list(METHODS)
    lines = ["| cloud | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
    for r in rows:
        cells = ["failed" if "error" in r["methods"][m] else
                 f"{r['methods'][m]['chamfer']:.3f} % · {r['methods'][m]['normal_error']:.1f}°" for m in methods]
        lines.append(f"| {r['shape']} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--shapes", default=",".join(SHAPES))
    p.add_argument("--points", type=int, default=30_000)
    p.add_argument("--noise", type=float, default=0.004, help="standard deviation, times the diagonal")
    p.add_argument("--out", default="cloud-output")
    args = p.parse_args(argv)
    rows = []
    for shape in args.shapes.split(","):
        rows.append(run_case(shape, args.points, args.noise))
        print(table(rows[-1:]).splitlines()[-1], flush=True)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(rows, f, indent=1)
    text = "Chamfer (% of the diagonal) · normal error\n\n" + table(rows)
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
