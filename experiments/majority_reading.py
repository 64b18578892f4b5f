"""Both sides of the surface decided ball by ball against the input's majority reading: how the window,
the thick parts and the kind of noise change what it leaves (issue 51, the round that gave
`skelfilter.core.decision.two_sided`).

    python -m experiments.majority_reading [--shapes cube bunny ...] [--kinds bumps-dents stripes ...]
                                           [--windows 9 11 13 15 17] [--seed 1] [--resolution 160]

Every variant works on the noise grid's masks (the input is the noisy mask, the fine pass off) and is
scored against the clean mask (`experiments.two_sided_readings.COLUMNS`, and the voxel-surface Chamfer:
the mean distance between the two masks' boundary voxels, both ways):

- ``foreground``: the foreground stage with its features kept (``stages`` foreground, the default
  before this round);
- ``proxy <w>``: the per-ball decision with the majority reading over a ``w``-wide cube in place of the
  clean shape (`two_sided.majority_reading`, `ball_owners.owned_output`, seams smoothed): every
  foreground ball centred outside it and every background ball centred inside it change their voxels;
- ``thick <w>``: the same on the reading's thick parts only (`two_sided.thick_parts` with a margin of 2
  voxels), in place of the foreground's result there, the foreground's result elsewhere;
- ``auto``: the default now (``stages`` auto: the dents read, the thick parts without the thin parts'
  feet).
"""

import argparse
import sys

import numpy as np
from scipy import ndimage

from benchmarks import quality, shapes
from experiments.two_sided_readings import COLUMNS, Case
from skelfilter.core import ball_owners, pipeline
from skelfilter.core.decision import two_sided
from skelfilter.params import DenoiseParams


def surface_chamfer(a, b):
    """Voxels: the mean distance from each mask's boundary voxels to the other's, averaged both ways."""
    def boundary(m):
        return m & ~ndimage.binary_erosion(m)
    sa, sb = boundary(a), boundary(b)
    return (ndimage.distance_transform_edt(~sb)[sa].mean() + ndimage.distance_transform_edt(~sa)[sb].mean()) / 2


def proxy(noisy, window):
    """The per-ball decision against the majority reading over ``window`` voxels, seams smoothed."""
    reading = two_sided.majority_reading(noisy, window)
    owners = [ball_owners.ray_owners(side) for side in (noisy, ball_owners.bounded_background(noisy))]
    flat = reading.reshape(-1)
    out = ball_owners.owned_output(noisy, *owners, ~flat[owners[0][2]], flat[owners[1][2]])
    return ball_owners.seam_smoothed(noisy, out), reading


def variants(noisy, resolution, windows):
    """(label, output mask) for every variant of the module's docstring."""
    params = DenoiseParams(resolution=resolution, fine_pass="off")
    foreground = pipeline.denoise_volume(noisy, params.with_(stages="foreground")).mask
    yield "foreground", foreground
    for window in windows:
        decided, reading = proxy(noisy, window)
        yield f"proxy {window}", decided
        yield f"thick {window}", np.where(two_sided.thick_parts(reading, window, margin=2.0), decided, foreground)
    yield "auto", pipeline.denoise_volume(noisy, params).mask


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--shapes", nargs="+", default=["cube", "bunny", "fin-plate"], choices=sorted(shapes.SHAPES))
    parser.add_argument("--kinds", nargs="+", default=["bumps-dents"], choices=sorted(quality.NOISE_KINDS))
    parser.add_argument("--windows", nargs="+", type=int, default=[9, 11, 13, 15, 17])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--resolution", type=int, default=160)
    args = parser.parse_args(argv)
    titles = [title for title, _ in COLUMNS] + ["chamfer"]
    print("| case | variant | " + " | ".join(titles) + " |\n|" + "---|" * (len(titles) + 2))
    for shape in args.shapes:
        for kind in args.kinds:
            case = Case(shape, kind, args.seed, args.resolution)
            noisy = case.noise.noisy
            for label, out in [("input", noisy), *variants(noisy, args.resolution, args.windows)]:
                values = [*case.scores(out), surface_chamfer(out, case.noise.clean)]
                cells = " | ".join("–" if np.isnan(v) else f"{v:.3f}" for v in values)
                print(f"| {shape} {kind} | {label} | {cells} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
