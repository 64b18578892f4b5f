"""A reading of the input's modal surface, and what it decides on two-sided noise (issue 51, seventh round).

    python -m experiments.modal_reading [--shapes fandisk spot ...] [--kinds bumps-dents] [--seed 1]
                                        [--taus 1 1.5] [--sigmas 4]

The two-sided decision needs a reading of where the clean surface is. The majority reading
(`two_sided.majority_reading`) spreads as wide as the noise (its surface 1-3 voxels either side of the
clean one). The *modal* reading (`two_sided.modal_reading`, the default's decision's since this round)
moves it to the height most of the input's surface sits at nearby: a trimmed local mean (a Gaussian of
``sigma`` voxels, over the surface voxels within ``tau`` of the running mean), not the bumps' tops or the
dents' floors.

Each case is the quality benchmark's (its cached noisy mesh, made first where missing), scored on the
noise grid against the clean mask and the clean mesh. For each reading (the clean mask itself, the
majority reading, the modal reading per ``tau`` and ``sigma``):

- ``offset``: percentiles 10/25/50/75/90 of the reading's surface voxels' signed distance to the clean
  surface (voxels, negative inside; the clean mask itself reads -1);
- ``every ball``: the per-ball decision on every ball against the reading (`benchmarks.oracle.owned_oracle`
  with the reading as its truth, seams smoothed), its mesh Chamfer to the clean mesh, bumps and dents left;
- ``holes``: the input's narrow holes (what a closing of the input by a ball of `HOLE_CLOSING` voxels adds:
  the dents, and the valleys between bumps) that the reading holds, added to the default's output (the
  noisy mesh denoised with no flags, voxelized), with the voxels the default removed within `HALO` voxels
  of them: its Chamfer, bumps and dents left, and the new material (voxels outside the clean shape and
  the bumps, over the clean volume). With the clean mask as the reading, the ceiling of the rule;
- ``guard``: whether the reading tells that the default's output is further from the clean mesh than
  the input (a guard of the whole result): the input's and the output's Chamfer to the reading's surface,
  against the truth.
"""

import os
import sys

import numpy as np
from scipy import ndimage

from benchmarks import oracle, quality
from experiments.chamfer_sides import case_parser, chamfer_halves, marching_mesh, signed_distance
from skelfilter.core import ball_owners
from skelfilter.core.decision import two_sided
from skelfilter.core.decision.feature_restore import ball_closing
from skelfilter.core.decision.two_sided import majority_reading, modal_reading
from skelfilter.core.neighbourhood import surface_voxels
from skelfilter.evaluation import metrics
from skelfilter.mesh import marching_cubes
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.mesh.voxelize import voxelize_on_grid
from skelfilter.params import DenoiseParams

# Voxels: the ball whose closing of the input gives its narrow holes (the thesis' dents are 2.1 in radius).
HOLE_CLOSING = 3.5
# Voxels around the holes within which what the default removed is given back (the halos).
HALO = 2.0
# Percentiles of the offsets printed.
PERCENTILES = (10, 25, 50, 75, 90)


def offsets(reading, clean):
    """`PERCENTILES` of the signed distance to ``clean``'s surface at ``reading``'s surface voxels."""
    return np.percentile(signed_distance(clean)[surface_voxels(reading)], PERCENTILES)


def readings(noisy, clean, taus, sigmas):
    """(label, reading) of the clean mask, the majority reading and the modal readings."""
    yield "clean", clean
    yield "majority", majority_reading(noisy)
    for tau in taus:
        for sigma in sigmas:
            yield f"modal, tau {tau:g}, sigma {sigma:g}", modal_reading(noisy, sigma=sigma, band=tau)


def case_rows(shape, kind, seed, taus, sigmas):
    setup = quality.Setup(160, os.path.abspath("benchmark-cache"), False, 900.0)
    case = quality.Case(shape, kind, seed)
    quality.prepare(case, setup)
    prep = quality.load_case(case, setup)
    noise, grid = prep.noise, prep.grid
    noisy, clean = noise.noisy, noise.clean
    output = mesh_pipeline.denoise_mesh(prep.marching, DenoiseParams())
    default = voxelize_on_grid(output, grid)
    holes = ball_closing(noisy, HOLE_CLOSING) & ~noisy
    truth = (chamfer_halves(prep.marching, prep)[0], chamfer_halves(output, prep)[0])

    def scores(mask):
        bumps = (mask & noise.bumps).sum() / noise.bumps.sum()
        dents = (noise.dents & ~mask).sum() / max(noise.dents.sum(), 1)
        return f"bumps left {bumps:.2f}, dents left {dents:.2f}"

    yield "truth", f"Chamfer input {truth[0]:.3f}, default {truth[1]:.3f}, {scores(default)}"
    for label, reading in readings(noisy, clean, taus, sigmas):
        yield label, "offset " + " / ".join(f"{value:.2f}" for value in offsets(reading, clean))
        decided = ball_owners.seam_smoothed(noisy, oracle.owned_oracle(noisy, reading))
        chamfer = metrics.surface_distances(marching_cubes.mask_to_mesh(decided, grid), prep.clean, grid)[0]
        yield label, f"every ball: Chamfer {chamfer:.3f}, {scores(decided)}"
        held = holes & reading
        filled = default | held | (noisy & (ndimage.distance_transform_edt(~held) <= HALO))
        new = (filled & ~clean & ~noise.bumps).sum() / clean.sum()
        yield label, (f"holes: Chamfer {chamfer_halves(marching_mesh(filled, grid), prep)[0]:.3f}, "
                      f"{scores(filled)}, new material {100 * new:.2f} %")
        if label != "clean":
            surface = marching_mesh(reading, grid)
            to_reading = [metrics.surface_distances(mesh, surface, grid)[0] for mesh in (prep.marching, output)]
            told = (to_reading[1] > to_reading[0]) == (truth[1] > truth[0])
            yield label, (f"guard: to the reading input {to_reading[0]:.3f}, default {to_reading[1]:.3f}: "
                          f"{'right' if told else 'wrong'}")


def main(argv=None):
    parser = case_parser(__doc__.split("\n")[0])
    parser.add_argument("--taus", nargs="+", type=float, default=[two_sided.MODAL_BAND])
    parser.add_argument("--sigmas", nargs="+", type=float, default=[two_sided.MODAL_SIGMA])
    args = parser.parse_args(argv)
    print("| case | reading | measures |\n|---|---|---|")
    for shape in args.shapes:
        for kind in args.kinds:
            for label, text in case_rows(shape, kind, args.seed, args.taus, args.sigmas):
                print(f"| {shape} {kind} | {label} | {text} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
