"""Can the default's own output tell whether the input has dents? A closing of the foreground stage's
result, read by the noise estimate, measured against the cases' known noise.

    python -m experiments.dent_closing [--shapes NAME ...] [--kinds stripes bumps-dents ...] [--seed 1]
                                       [--resolution 128] [--radii 3 4 6]

For each case (a benchmark shape, clean or with the thesis' noise of `quality.NOISE_KINDS` at
``--resolution``), the default runs on the noisy voxels (`pipeline.denoise_volume`: the foreground
stage removes the bumps, the dents stay). Its result K is closed by a ball of radius ``r`` voxels (the
measured bump height where the stage found noise, else each of ``--radii``): what the closing fills is
the dents and the shape's real concavities (concave edges, a mug's inside), filled to depth r at most.
The noise estimate reads what was filled as the background stage's pruning would be read
(`noise_estimate.estimate_noise` on the background ~K against the closing's background): dents are many
low peaks all over the surface, a concave edge a few ridges. Printed per case: the stage's bump
estimate, the filled share (of K's volume), the filled depth (filled voxels per surface voxel of K) and
the dent estimate (found, height, coverage) per radius; then, per radius, the AUC of each for "the noise
has dents" and how many cases with and without dents read as found. Read in
docs/design/noise-estimate.md (both sides and thick parts).
"""

import argparse
import json
import sys

import numpy as np
from scipy import ndimage

from benchmarks import quality, shapes
from experiments.ball_oracle import auc
from skelfilter.core import pipeline
from skelfilter.core.decision import feature_restore, noise_estimate
from skelfilter.mesh import pipeline as mesh_pipeline

KINDS = ("clean", "stripes", "high", "sparse", "bumps-dents")


def dent_reading(kept, radius, resolution):
    """The noise estimate of what closing ``kept`` by ``radius`` fills, read as dents."""
    closed = feature_restore.ball_closing(kept, radius)
    estimate = noise_estimate.estimate_noise(~kept, ~closed, resolution, "dents")
    filled = int((closed & ~kept).sum())
    surface = int((kept & ~ndimage.binary_erosion(kept)).sum())
    return {"filled": float(filled / max(kept.sum(), 1)), "depth": float(filled / max(surface, 1)),
            "found": bool(estimate.found), "height": round(float(estimate.height), 2),
            "coverage": round(float(estimate.coverage), 4)}


def run_case(shape, kind, seed, resolution, radii):
    noise_kind = "bumps-dents" if kind == "clean" else kind
    case = quality.Case(shape, noise_kind, seed)
    _, noise, _ = mesh_pipeline.noisy_mesh(shapes.load(shape), case.noise(resolution))
    volume = noise.clean if kind == "clean" else noise.noisy
    result = pipeline.denoise_volume(volume)
    bumps = result.noise.get("foreground")
    row = {"shape": shape, "kind": kind, "split": quality.split_of(shape), "dents": kind == "bumps-dents",
           "bumps": None if bumps is None else {"found": bool(bumps.found), "height": round(float(bumps.height), 2)}}
    measured = bumps.height if bumps is not None and bumps.found else None
    for radius in ([measured] if measured else []) + list(radii):
        key = "measured" if radius is measured else f"r{radius:g}"
        row[key] = dent_reading(result.mask, radius, resolution)
    return row


def summary(rows, keys):
    for key in keys:
        have = [r for r in rows if key in r]
        if not have:
            continue
        truth = np.array([r["dents"] for r in have])
        coverage = np.array([r[key]["coverage"] for r in have])
        filled = np.array([r[key]["filled"] for r in have])
        depth = np.array([r[key]["depth"] for r in have])
        found = np.array([r[key]["found"] for r in have])
        print(f"== {key}: AUC of the coverage {auc(coverage, truth):.3f}, of the filled share "
              f"{auc(filled, truth):.3f}, of the filled depth {auc(depth, truth):.3f}; found on "
              f"{int(found[truth].sum())} of {int(truth.sum())} with dents, {int(found[~truth].sum())} of "
              f"{int((~truth).sum())} without")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shapes", nargs="+", default=sorted(shapes.SHAPES), choices=sorted(shapes.SHAPES))
    parser.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--radii", nargs="+", type=float, default=[3.0, 4.0, 6.0])
    args = parser.parse_args(argv)
    rows = []
    for shape in args.shapes:
        for kind in args.kinds:
            rows.append(run_case(shape, kind, args.seed, args.resolution, args.radii))
            print(json.dumps(rows[-1]), flush=True)
    summary(rows, ["measured"] + [f"r{r:g}" for r in args.radii])
    return rows


if __name__ == "__main__":
    sys.exit(main() and 0)
