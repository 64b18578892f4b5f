"""Can the noisy shape alone tell whether its noise has dents? A majority-filter reference, measured
against the cases' known noise.

    python -m experiments.dent_indicator [--shapes NAME ...] [--kinds stripes bumps-dents ...]
                                        [--windows 5 7 9 11] [--seed 1] [--resolution 160]

For each case (a benchmark shape, the thesis' noise of `quality.NOISE_KINDS` at ``--resolution``) the
reference surface is the level 1/2 of the noisy mask's mean over a cube of ``window`` voxels (the
majority filter, a binary median). The indicator is the *deep* background (voxels outside the noisy
shape where the mean is at least `DEEP`) over the *high* foreground (voxels inside it where the mean is
below 1 - `DEEP`): dents are background below the reference, bumps foreground above it. Printed: each
case's indicator per window, then the AUC of the indicator for "the noise has dents" per split, over
all kinds and over the kinds of equal density and height (stripes against bumps-dents), and per kind
how many cases read as dents below `THRESHOLD` (the smallest window).
"""

import argparse
import sys

import numpy as np
from scipy import ndimage

from benchmarks import quality, shapes
from experiments.ball_oracle import auc
from skelfilter.mesh import pipeline as mesh_pipeline

DEEP = 0.65  # the mean over the window that puts a voxel well inside the reference
THRESHOLD = 0.6  # the indicator below which a case reads as having dents
PAIRED_KINDS = ("stripes", "bumps-dents")  # the same density and height, without and with dents


def indicator(noisy, window):
    """Deep background over high foreground around the majority-filter reference of ``noisy``."""
    mean = ndimage.uniform_filter(noisy.astype(np.float32), size=window)
    deep = int(((mean >= DEEP) & ~noisy).sum())
    high = int(((mean < 1.0 - DEEP) & noisy).sum())
    return deep / max(high, 1)


def run_case(shape, kind, seed, resolution, windows):
    case = quality.Case(shape, kind, seed)
    _, noise, _ = mesh_pipeline.noisy_mesh(shapes.load(shape), case.noise(resolution))
    return {"case": case.name, "kind": kind, "split": case.split, "dents": bool(noise.dents.any()),
            "indicator": [indicator(noise.noisy, w) for w in windows]}


def summary(rows, windows):
    for split in quality.SPLITS:
        part = [r for r in rows if r["split"] == split]
        for label, chosen in (("all kinds", part), ("stripes against bumps-dents",
                                                    [r for r in part if r["kind"] in PAIRED_KINDS])):
            dents = np.array([r["dents"] for r in chosen])
            if dents.all() or not dents.any():
                continue
            areas = ", ".join(f"window {w}: {auc(np.array([r['indicator'][i] for r in chosen]), dents):.3f}"
                              for i, w in enumerate(windows))
            print(f"{split}, {label} ({len(chosen)} cases): AUC {areas}")
        for kind in sorted({r["kind"] for r in part}):
            values = [r["indicator"][0] for r in part if r["kind"] == kind]
            print(f"{split}, {kind}: read as dents (window {windows[0]}, below {THRESHOLD}) on "
                  f"{sum(v < THRESHOLD for v in values)} of {len(values)}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--shapes", nargs="+", default=sorted(shapes.SHAPES), choices=sorted(shapes.SHAPES))
    parser.add_argument("--kinds", nargs="+", default=sorted(quality.NOISE_KINDS), choices=sorted(quality.NOISE_KINDS))
    parser.add_argument("--windows", nargs="+", type=int, default=[5, 7, 9, 11])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--resolution", type=int, default=160)
    args = parser.parse_args(argv)
    rows = []
    for shape in args.shapes:
        for kind in args.kinds:
            row = run_case(shape, kind, args.seed, args.resolution, args.windows)
            rows.append(row)
            print(f"{row['case']} ({row['split']}, dents: {'yes' if row['dents'] else 'no'}): "
                  + ", ".join(f"{v:.2f}" for v in row["indicator"]), flush=True)
    summary(rows, args.windows)


if __name__ == "__main__":
    sys.exit(main())
