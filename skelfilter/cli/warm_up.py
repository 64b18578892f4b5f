"""Compile every numba kernel ahead of its first use: ``python -m skelfilter.cli.warm_up``.

numba compiles a kernel at its first call, about 40 s for the whole pipeline, and with
``cache=True`` keeps the machine code beside the source for every later process. The set-up
(``make setup``) runs this module, so that the first denoise takes as long as any other: it runs
each path of the pipeline once on a small grid, which calls every kernel with the argument types
of a real run (the types, not the sizes, choose the machine code).
"""

import sys
import time

import trimesh

from skelfilter.core.decision import pruning_rules
from skelfilter.io import mesh_files
from skelfilter.io.samples import sample_path
from skelfilter.mesh import guided_filtering, normal_filtering, voxelize
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.params import DenoiseParams, NoiseParams
from skelfilter.runtime import worker_threads

RESOLUTION = 32


def compile_kernels():
    """Run the noise and every denoising path on the embedded sample at `RESOLUTION`; returns the
    seconds it took."""
    start = time.perf_counter()
    worker_threads.start()
    clean = mesh_files.load_mesh(sample_path())
    noisy = mesh_pipeline.noisy_mesh(clean, NoiseParams(resolution=RESOLUTION, seed=1))[0]
    # Pruned as told with a given noise height: at this size no noise is found, and the features are
    # given back by it.
    for params in (DenoiseParams(resolution=RESOLUTION, output_mesh="closed", prune="as-told", noise_height=2.0),
                   DenoiseParams(resolution=RESOLUTION, output_mesh="input"),
                   DenoiseParams(resolution=RESOLUTION, preset="thesis")):
        mesh_pipeline.denoise_mesh(noisy, params)
    # The thesis' alternatives to its final pipeline (their kernels and argument types): every pruning
    # rule, and the other EDT filters, velocities and skeletons.
    rules = [{"pruning": name} for name in pruning_rules.RULES if name != DenoiseParams().pruning]
    for variant in (*rules, {"edt_filter": "opening"}, {"edt_filter": "explicit-mean"},
                    {"edt_filter": "least-squares", "velocity": "importance-gradient"},
                    {"skeleton": "usm", "velocity": "unified"}):
        mesh_pipeline.denoise_mesh(noisy, DenoiseParams(resolution=RESOLUTION, preset="thesis", **variant))
    # An open mesh: the voxelization's hole handling (a new closed mesh of it is refused).
    half = trimesh.Trimesh(clean.vertices, clean.faces[clean.triangles_center[:, 2] < clean.centroid[2]],
                           process=False)
    voxelize.voxelize(half, RESOLUTION)
    # The guided normal filter, which the fine pass runs only on piecewise-flat noisy meshes.
    normals, areas, centroids = normal_filtering.face_geometry(clean.vertices, clean.faces)
    guided_filtering.guided_normals(normals, areas, centroids,
                                    normal_filtering.face_neighbours(clean.faces, len(clean.vertices)),
                                    guided_filtering.edge_neighbours(clean.faces), 0.35, 1)
    return time.perf_counter() - start


def main():
    print("skelfilter: compiling the numba kernels (once per installation)...", file=sys.stderr, flush=True)
    print(f"skelfilter: kernels ready ({compile_kernels():.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
