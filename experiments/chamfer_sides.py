"""Where the default's Chamfer distance on two-sided noise comes from, and what would take it below the
input's (issue 51, sixth round).

    python -m experiments.chamfer_sides [--shapes fandisk spot ...] [--kinds bumps-dents] [--seed 1]
                                        [--laplacian] [--readings] [--precision]

Each case is the quality benchmark's (its cached noisy mesh, made first where missing), denoised with no
flags as a user runs it (the route finds the voxel lattice the noisy mesh was made on). Per case:

- ``input`` / ``default``: the mesh Chamfer distance to the clean mesh (`metrics.surface_distances`), its
  area over the clean mesh's, and the distance's two halves, the mean distance from the result's surface
  to the clean one (``r→c``: what stands out) and from the clean surface to the result's (``c→r``: what
  the result lost or moved away from);
- on the noise grid, the default's voxels (its mesh voxelized) as a marching-cubes surface, and the same
  voxels repaired by the truth: the ``halos`` given back (clean voxels outside the dents that the output
  lost), the ``dents`` filled, the ``bumps`` left taken off;
- the dent-rim guard: the voxels the default removed within ``δ`` voxels of the input's narrow holes
  (what a closing of the input by a ball of `HOLE_CLOSING` voxels adds) given back, with the bumps left;
- ``--laplacian``: MeshLab's surface-preserving Laplacian (the benchmark's rival, 60°, 50 iterations) on
  the input's decimated mesh and on the default's output;
- ``--precision``: how precise a reading has to be. The per-ball oracle (`benchmarks.oracle.owned_oracle`,
  seams smoothed, as the quality benchmark's ``--oracle``) decides against the clean shape; here against
  the clean shape's surface moved by a smooth random field of standard deviation σ voxels (white noise
  smoothed by a Gaussian of `PRECISION_LENGTH` voxels, rescaled), or moved in by ``b`` voxels everywhere,
  and against the input's majority reading (every ball decided by it, not only where the default trusts
  it, and not only to add to the foreground's result);
- ``--readings``: the input's majority reading (`two_sided.majority_reading`) per window and threshold:
  the offset of its surface from the clean shape's (quartiles, voxels, negative inside; a reading equal
  to the clean mask reads -1, its surface voxels being the inner layer) and the shares of the clean
  voxels within `NEAR` of the clean surface it holds and of the others it leaves out.
"""

import argparse
import importlib
import os
import sys

import numpy as np
import trimesh
from scipy import ndimage
from skimage import measure

from benchmarks import oracle, quality, shapes
from skelfilter.core import ball_owners
from skelfilter.core.decision import two_sided
from skelfilter.core.decision.feature_restore import ball_closing
from skelfilter.evaluation import metrics
from skelfilter.mesh import marching_cubes
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.mesh.voxelize import voxelize_on_grid
from skelfilter.params import DenoiseParams

# The module, not the function the metrics package exports under its name: its directed distances.
distances = importlib.import_module("skelfilter.evaluation.metrics.surface_distances")

# Voxels: the ball whose closing of the input gives its narrow holes (the thesis' dents, 2.1 voxels in
# radius, and the valleys between bumps).
HOLE_CLOSING = 2.5
# Voxels from the clean surface within which the readings are scored.
NEAR = 4
# Voxels: the correlation length of the random field that moves the clean surface (``--precision``).
PRECISION_LENGTH = 4.0


def marching_mesh(mask, grid):
    """The marching-cubes surface of ``mask``'s indicator at one half, in the grid's coordinates: the voxels'
    own staircase (`marching_cubes.mask_to_mesh`, which the quality benchmark's oracle uses, goes through
    the mask's distance field instead)."""
    vertices, faces, _, _ = measure.marching_cubes(np.pad(mask, 1).astype(np.float32), 0.5)
    return trimesh.Trimesh((vertices - 1) * grid.pitch + grid.origin, faces, process=False)


def chamfer_halves(mesh, prep):
    """(Chamfer, r→c mean, c→r mean) of ``mesh`` against the case's clean mesh, in noise-grid voxels."""
    to_clean, from_clean = distances._distances(mesh, prep.clean, prep.grid, distances.N_SAMPLES, distances.SEED)
    return 0.5 * (to_clean.mean() + from_clean.mean()), to_clean.mean(), from_clean.mean()


def laplacian(mesh):
    """MeshLab's surface-preserving Laplacian with the benchmark rival's settings."""
    import pymeshlab

    meshes = pymeshlab.MeshSet()
    meshes.add_mesh(pymeshlab.Mesh(np.asarray(mesh.vertices, float), np.asarray(mesh.faces)))
    meshes.apply_coord_laplacian_smoothing_surface_preserving(angledeg=60, iterations=50)
    out = meshes.current_mesh()
    return trimesh.Trimesh(out.vertex_matrix(), out.face_matrix(), process=False)


def rim_guard(noisy, output, delta):
    """``output`` with the voxels it removed from ``noisy`` within ``delta`` voxels of the input's narrow
    holes given back: the changes that widen a dent not made."""
    holes = ball_closing(noisy, HOLE_CLOSING) & ~noisy
    return output | (noisy & ~output & (ndimage.distance_transform_edt(~holes) <= delta))


def signed_distance(mask):
    """Voxels to ``mask``'s surface, negative inside (its inner layer -1)."""
    return ndimage.distance_transform_edt(~mask) - ndimage.distance_transform_edt(mask)


def reading_rows(noise):
    """The majority readings' offsets and shares (see the module's docstring)."""
    clean = noise.clean
    signed = signed_distance(clean)
    near = np.abs(signed) <= NEAR
    rows = []
    for window in (11, 15):
        share = ndimage.uniform_filter(noise.noisy.astype(np.float32), window, mode="constant")
        for threshold in (0.5, 0.45):
            reading = share > threshold
            surface = reading & ~ndimage.binary_erosion(reading)
            quartiles = np.percentile(signed[surface], [25, 50, 75])
            held = (reading & clean & near).sum() / (clean & near).sum()
            left_out = (~reading & ~clean & near).sum() / (~clean & near).sum()
            rows.append((f"reading {window}, > {threshold:g}",
                         f"offset {quartiles[0]:.2f} / {quartiles[1]:.2f} / {quartiles[2]:.2f}, "
                         f"clean held {held:.2f}, outside left out {left_out:.2f}"))
    return rows


def moved_readings(noise, seed):
    """(label, mask) of the clean shape with its surface moved (see the module's docstring), and the
    input's majority reading for comparison."""
    clean = noise.clean
    signed = signed_distance(clean)
    field = ndimage.gaussian_filter(np.random.default_rng(seed).standard_normal(clean.shape), PRECISION_LENGTH)
    field /= field.std()
    yield from ((f"oracle, surface moved by σ {sigma:g}", signed + sigma * field < 0) for sigma in (0, 0.5, 1, 2))
    yield from ((f"oracle, surface moved in by {inward:g}", signed + inward < 0) for inward in (0.5, 1))
    yield "every ball against the majority reading", two_sided.majority_reading(noise.noisy)


def case_rows(shape, kind, seed, with_laplacian, with_readings, with_precision=False):
    setup = quality.Setup(160, os.path.abspath("benchmark-cache"), False, 900.0)
    case = quality.Case(shape, kind, seed)
    quality.prepare(case, setup)
    prep = quality.load_case(case, setup)
    noise, grid = prep.noise, prep.grid
    output = mesh_pipeline.denoise_mesh(prep.marching, DenoiseParams())
    rows = [(label, "Chamfer {:.3f} (r→c {:.3f}, c→r {:.3f}), area {:.2f} of the clean mesh's".format(
                *chamfer_halves(mesh, prep), mesh.area / prep.clean.area))
            for label, mesh in (("input", prep.marching), ("default", output))]
    voxels = voxelize_on_grid(output, grid)
    lost = noise.clean & ~noise.dents & ~voxels

    def on_grid(label, mask):
        bumps = (mask & noise.bumps).sum() / noise.bumps.sum()
        dents = (noise.dents & ~mask).sum() / max(noise.dents.sum(), 1)
        rows.append((label, f"Chamfer {chamfer_halves(marching_mesh(mask, grid), prep)[0]:.3f}, "
                            f"bumps left {bumps:.2f}, dents left {dents:.2f}"))

    on_grid("noise grid: input", noise.noisy)
    on_grid("noise grid: default", voxels)
    on_grid("+ halos given back (truth)", voxels | lost)
    on_grid("+ dents filled (truth)", voxels | noise.dents)
    on_grid("- bumps left (truth)", voxels & ~noise.bumps)
    on_grid("all three (truth)", (voxels | lost | noise.dents) & ~noise.bumps)
    for delta in (1, 2):
        on_grid(f"dent-rim guard, δ {delta}", rim_guard(noise.noisy, voxels, delta))
    if with_laplacian:
        rows += [(label, f"Chamfer {metrics.surface_distances(laplacian(mesh), prep.clean, grid)[0]:.3f}")
                 for label, mesh in (("Laplacian of the input", prep.decimated), ("Laplacian of the default", output))]
    if with_precision:
        for label, reading in moved_readings(noise, seed):
            decided = ball_owners.seam_smoothed(noise.noisy, oracle.owned_oracle(noise.noisy, reading))
            mesh = marching_cubes.mask_to_mesh(decided, grid)
            bumps = (decided & noise.bumps).sum() / noise.bumps.sum()
            dents = (noise.dents & ~decided).sum() / max(noise.dents.sum(), 1)
            rows.append((label, f"Chamfer {metrics.surface_distances(mesh, prep.clean, grid)[0]:.3f}, "
                                f"bumps left {bumps:.2f}, dents left {dents:.2f}"))
    if with_readings:
        rows += reading_rows(noise)
    return rows


def case_parser(description):
    """A parser of the quality benchmark's cases these experiments run: ``--shapes``, ``--kinds``, ``--seed``."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--shapes", nargs="+", default=["fandisk", "spot", "cube", "quadruped"],
                        choices=sorted(shapes.SHAPES))
    parser.add_argument("--kinds", nargs="+", default=["bumps-dents"], choices=sorted(quality.NOISE_KINDS))
    parser.add_argument("--seed", type=int, default=1)
    return parser


def main(argv=None):
    parser = case_parser(__doc__.split("\n")[0])
    parser.add_argument("--laplacian", action="store_true", help="also MeshLab's Laplacian (needs pymeshlab)")
    parser.add_argument("--readings", action="store_true", help="also the majority readings' offsets")
    parser.add_argument("--precision", action="store_true", help="also the oracle against a moved clean surface")
    args = parser.parse_args(argv)
    print("| case | result | measures |\n|---|---|---|")
    for shape in args.shapes:
        for kind in args.kinds:
            for label, text in case_rows(shape, kind, args.seed, args.laplacian, args.readings, args.precision):
                print(f"| {shape} {kind} | {label} | {text} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
