"""What the noise estimate finds after the default's pruning: clean shapes against noisy ones.

    python -m experiments.noise_coverage [--groups clean thesis segmentation] [--shapes NAME ...]

Each case's mask is cropped and padded as `skelfilter.core.pipeline.denoise_volume` does, its
skeleton pruned by the default's foreground stage (`stage_pruning.stage_at_noise_scale`: at t, and at t / 2
and t / 4 where that keeps under a quarter of the shape and finds nothing), and the estimate
(`skelfilter.core.decision.noise_estimate.estimate_noise`) taken on what the pruning removed. Groups:

- ``clean``: the 17 shapes of `shapes.SHAPES` voxelized on the grids of `CLEAN_GRIDS` (128-224
  voxels; at two paddings the cells over which the coverage is counted fall differently on the
  shape); every one should pass through;
- ``thesis``: the thesis' noise of `quality.NOISE_KINDS` at 160 voxels, seeds 1 and 2;
- ``segmentation``: `volumes.segmentation_noise` at its three strengths, 128 voxels.

Prints one line per case (coverage, found, height) and per group and split: the cases found, and the
smallest, median and largest coverage.
"""

import argparse

import numpy as np

from benchmarks import quality, shapes, volumes
from skelfilter.core import pipeline
from skelfilter.core.decision import stage_pruning
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.mesh.voxelize import grid_for_bounds, voxelize_on_grid
from skelfilter.runtime.progress import Progress

CLEAN_GRIDS = ((128, 6), (128, 9), (160, 6), (160, 9), (192, 6), (192, 9), (224, 7))


def estimate(mask):
    """The default foreground stage's noise estimate on ``mask``, as the volume path runs it."""
    mask = mask[pipeline._crop(mask)]
    params, pad = pipeline._cubic_params(mask, pipeline.resolve_params())
    padded = np.pad(mask, pad)
    return stage_pruning.stage_at_noise_scale(padded, params, "bumps", Progress(enabled=False))[1]


def cases(group, names):
    """(case name, split, mask) of a group."""
    for name in names:
        split = quality.split_of(name)
        if group == "clean":
            mesh = shapes.load(name)
            for resolution, padding in CLEAN_GRIDS:
                yield f"{name} {resolution}/{padding}", split, \
                    voxelize_on_grid(mesh, grid_for_bounds(mesh.bounds, resolution, padding))
        elif group == "thesis":
            for kind in quality.NOISE_KINDS:
                for seed in quality.SEEDS:
                    case = quality.Case(name, kind, seed)
                    yield case.name, split, mesh_pipeline.noisy_mesh(shapes.load(name), case.noise(160))[1].noisy
        else:
            clean = volumes.clean_mask(name, 128)
            for strength, (amplitude, sigma) in volumes.STRENGTHS.items():
                yield f"{name} {strength}", split, volumes.segmentation_noise(clean, amplitude, sigma, 1)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--groups", nargs="+", default=["clean", "thesis", "segmentation"],
                   choices=["clean", "thesis", "segmentation"])
    p.add_argument("--shapes", nargs="+", default=list(shapes.SHAPES), choices=list(shapes.SHAPES))
    args = p.parse_args(argv)
    for group in args.groups:
        rows = []
        for name, split, mask in cases(group, args.shapes):
            e = estimate(mask)
            rows.append((split, e))
            found = f"found, height {e.height:.1f}" if e.found else "none found"
            print(f"{group} {name} ({split}): coverage {e.coverage:.3f}, {found}", flush=True)
        for split in quality.SPLITS:
            own = [e for s, e in rows if s == split]
            if own:
                cover = np.array([e.coverage for e in own])
                print(f"== {group}, {split}: found on {sum(e.found for e in own)} of {len(own)}; coverage "
                      f"min {cover.min():.3f}, median {np.median(cover):.3f}, max {cover.max():.3f}")


if __name__ == "__main__":
    main()
