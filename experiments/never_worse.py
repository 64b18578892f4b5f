"""Never worse than the input, change by change: what a guard that undoes the default's changes that
move away from the truth would give (its oracle), and how often the input's majority reading takes the
oracle's decision (issue 51, item 1).

    python -m experiments.never_worse [--shapes cube bunny ...] [--kinds bumps-dents ...] [--block 0 8 16]
                                      [--window 15] [--seed 1] [--resolution 160] [--path volume mesh]
                                      [--own-lattice]

``--path volume``: on the noise grid's masks (the input is the noisy mask, the fine pass off); ``mesh``:
as the quality benchmark runs it, the noisy mesh through `denoise_mesh` at ``--resolution`` (a grid of
the noisy mesh's own box, not the noise's), its masks on that grid, and also the Chamfer distance of the
meshes to the clean mesh (`metrics.surface_distances`, "mesh chamfer": the input mesh, the output mesh,
the guards' masks through the default's smooth surface); with ``--own-lattice`` the noisy mesh is denoised
with no resolution given, as a user runs it (the route finds the voxel lattice the noisy mesh was made
on). The default's output O
differs from the input N in its changed voxels O ^ N. They are cut into pieces: their 26-connected
components, each further cut by the cubes of a ``--block``-voxel lattice (0: not cut). A guard keeps a
piece's change where the output agrees with a reference on at least as many of the piece's voxels as
the input does, and gives the piece back its input voxels elsewhere:

- ``oracle``: the reference is the clean mask (the best a guard deciding piece by piece can do);
- ``reading``: the reference is the input's majority reading over a ``--window``-wide cube
  (`two_sided.majority_reading`), which a guard can compute.

Per case: the voxel-surface Chamfer (`experiments.majority_reading.surface_chamfer`) of the input, the
output and both guards against the clean mask, and the share of the changed voxels whose piece the
reading decides as the oracle does ("agree"); on the volume path also the scores of
`experiments.two_sided_readings.COLUMNS`.
"""

import argparse
import sys

import numpy as np
from scipy import ndimage

from benchmarks import quality, shapes
from experiments.majority_reading import surface_chamfer
from experiments.two_sided_readings import COLUMNS, Case
from skelfilter.core import pipeline, surface_field
from skelfilter.core.decision import two_sided
from skelfilter.evaluation import metrics
from skelfilter.mesh import marching_cubes, voxelize
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.params import DenoiseParams


def pieces(changed, block):
    """Labels (0 outside ``changed``) of the changed voxels' 26-components, cut by ``block``-voxel cubes."""
    labels, count = ndimage.label(changed, structure=np.ones((3, 3, 3), bool))
    if block:
        cells = tuple(-(-n // block) for n in changed.shape)
        cell = np.ravel_multi_index(np.broadcast_arrays(*np.ix_(*[np.arange(n) // block for n in changed.shape])),
                                    cells)
        key = np.where(changed, labels.astype(np.int64) * int(np.prod(cells)) + cell, -1)
        _, labels = np.unique(key, return_inverse=True)
        labels = labels.reshape(changed.shape)  # 0 is the unchanged voxels' key (-1, the smallest)
    return labels


def guarded(noisy, out, labels, reference):
    """``out`` with each piece's change kept where ``out`` agrees with ``reference`` on at least as many
    of its voxels as ``noisy``; the kept pieces (bool per label)."""
    changed = labels > 0
    agree = np.bincount(labels[changed], weights=(out == reference)[changed], minlength=labels.max() + 1)
    size = np.bincount(labels[changed], minlength=labels.max() + 1)
    keep = 2 * agree >= size
    keep[0] = True
    return np.where(keep[labels], out, noisy), keep, size


def volume_case(case, params):
    """(input, clean, output) masks on the noise grid, and no mesh measure."""
    noisy = case.noise.noisy
    return noisy, case.noise.clean, pipeline.denoise_volume(noisy, params.with_(fine_pass="off")).mask, None


def mesh_case(shape, kind, seed, resolution, params):
    """(input, clean, output) masks on the grid `denoise_mesh` chose, and a function giving a mask's
    mesh Chamfer (the mesh itself for the input and output)."""
    clean_mesh = shapes.load(shape)
    noisy_mesh, _, noise_grid = mesh_pipeline.noisy_mesh(clean_mesh, quality.Case(shape, kind, seed).noise(resolution))
    out, result, grid = mesh_pipeline.denoise_mesh_detailed(noisy_mesh, params)
    if result.mask is None or result.mask.shape != grid.shape:
        return None  # the voxel stage did not run
    chamfer = {}

    def mesh_chamfer(label, mask):
        if label not in chamfer:
            given = {"input": noisy_mesh, "default": out}
            mesh = given[label] if label in given else marching_cubes.smooth_field_to_mesh(
                surface_field.mask_field(mask), mask, grid)
            chamfer[label] = metrics.surface_distances(mesh, clean_mesh, noise_grid)[0]
        return chamfer[label]

    noisy = voxelize.voxelize_on_grid(noisy_mesh, grid)
    return noisy, voxelize.voxelize_on_grid(clean_mesh, grid), result.mask, mesh_chamfer


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--shapes", nargs="+", default=sorted(shapes.SHAPES), choices=sorted(shapes.SHAPES))
    parser.add_argument("--kinds", nargs="+", default=["bumps-dents"], choices=sorted(quality.NOISE_KINDS))
    parser.add_argument("--block", nargs="+", type=int, default=[0, 8])
    parser.add_argument("--window", type=int, default=two_sided.MAJORITY_WINDOW)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--resolution", type=int, default=160)
    parser.add_argument("--path", choices=("volume", "mesh"), default="volume")
    parser.add_argument("--own-lattice", action="store_true", help="mesh path: no resolution given")
    args = parser.parse_args(argv)
    titles = (["voxel chamfer", "agree"] + ([title for title, _ in COLUMNS] if args.path == "volume" else
                                             ["mesh chamfer"]))
    print("| case | variant | " + " | ".join(titles) + " |\n|" + "---|" * (len(titles) + 2))
    params = DenoiseParams(resolution=args.resolution)
    for shape in args.shapes:
        for kind in args.kinds:
            if args.path == "volume":
                case = Case(shape, kind, args.seed, args.resolution)
                masks = volume_case(case, params)
            else:
                masks = mesh_case(shape, kind, args.seed, args.resolution,
                                  DenoiseParams() if args.own_lattice else params)
                if masks is None:
                    print(f"| {shape} {kind} | the voxel stage did not run |", flush=True)
                    continue
            noisy, clean, out, mesh_chamfer = masks
            reading = two_sided.majority_reading(noisy, args.window)
            rows = [("input", noisy, np.nan), ("default", out, np.nan)]
            for block in args.block:
                labels = pieces(out ^ noisy, block)
                by_oracle, oracle_keeps, size = guarded(noisy, out, labels, clean)
                by_reading, reading_keeps, _ = guarded(noisy, out, labels, reading)
                agree = float(size[oracle_keeps == reading_keeps].sum() / max(size.sum(), 1))
                rows += [(f"oracle, block {block}", by_oracle, np.nan), (f"reading, block {block}", by_reading, agree)]
            for label, mask, agree in rows:
                values = [surface_chamfer(mask, clean), agree]
                values += [*case.scores(mask)] if args.path == "volume" else [mesh_chamfer(label, mask)]
                cells = " | ".join("–" if np.isnan(v) else f"{v:.3f}" for v in values)
                print(f"| {shape} {kind} | {label} | {cells} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
