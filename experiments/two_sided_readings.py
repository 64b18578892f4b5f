"""Issue 51's first measurements: what the default leaves on two-sided noise and on thick parts, and
whether a reading of the input alone can tell the halos, the dents and the restored bumps apart.

    python -m experiments.two_sided_readings [--shapes cube bunny ...] [--kinds bumps-dents stripes ...]
                                            [--seed 1] [--resolution 160] [--median]

Every variant works on the noise grid's masks (the input is the noisy mask; the default is
``denoise_volume`` with the fine pass off, which the thesis noise at 160 voxels does not run on
meshes either) and is scored against the clean mask:

- ``default``; ``pruned``: its pruning before the features kept; ``restored``: the steps of
  `feature_restore.keep_features` one by one, to see which gives back the bumps on thick parts.
- ``balls over <radius> voxels kept``: the pruning keeps every ball that large whatever its
  importance (too large to be a bump: would they carry the parts the restoring gives back whole?).
- ``halo g<sigma>@<level>``: the default, plus the voxels it removed where the input's Gaussian of
  ``sigma`` is at least ``level`` (deep inside a smooth reading: the halos beside the dents).
- ``closing <radius>``: the default plus what a closing of its own output by a ball of ``radius``
  fills (its depressions: halos, then dents).
- ``both stages`` (with the background's own estimate: whether it finds dents) and ``background,
  foreground estimate``: the background's features kept with the foreground's noise height in place
  of its own.
- ``proxy g<sigma>``: the per-ball oracle (`oracle.owned_oracle`, seam smoothed) with the
  input's Gaussian reading in place of the clean shape; with ``--median``, ``median <w>`` (the
  level 0 of the input's signed distance median-filtered over ``w`` voxels: the modal surface,
  slow) and ``proxy median <w>``.

Columns: bumps left, bumps left on parts thicker than twice the noise height, dents left, clean lost,
new material, the clean shape's concavities filled, the voxel error over the input's, thin parts kept
(as `quality.score` counts them on the noise grid).
"""

import argparse
import sys

import numpy as np
from scipy import ndimage

from benchmarks import oracle, quality, shapes
from skelfilter.core import ball_owners, pipeline
from skelfilter.core.decision import feature_restore, noise_estimate, pruning_rules
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.params import DenoiseParams

# (column title, `quality.voxel_measures` key)
COLUMNS = (("bumps", "bumps_left"), ("thick bumps", "bumps_left_over_2h"), ("dents", "dents_left"),
           ("lost", "clean_lost"), ("new", "new_material"), ("concavities", "concavity_filled"),
           ("error", "error_ratio"), ("thin kept", "thin_kept"))


class Case:
    """A case's masks and what the measures compare a result with (`quality.voxel_references`)."""

    def __init__(self, shape, kind, seed, resolution):
        noise_params = quality.Case(shape, kind, seed).noise(resolution)
        _, self.noise, _ = mesh_pipeline.noisy_mesh(shapes.load(shape), noise_params)
        self.references = quality.voxel_references(self.noise, kind)
        self.resolution = resolution

    def scores(self, out):
        measures = quality.voxel_measures(out, self.noise, *self.references)
        return tuple(measures[key] for _, key in COLUMNS)


class Recorder:
    """`feature_restore.keep_features`' steps and the noise estimates, recorded as the default runs."""

    STEPS = ("features_by_extent", "along_lines", "connections", "skin_far_from_noise")

    def __init__(self):
        self.steps, self.estimates, self.foreground_estimate = {}, {}, None
        self._original = {name: getattr(feature_restore, name) for name in self.STEPS}
        self._estimate = noise_estimate.estimate_noise

    def __enter__(self):
        for name in self.STEPS:
            setattr(feature_restore, name, self._recording(name))
        noise_estimate.estimate_noise = self._estimating
        return self

    def __exit__(self, *exc):
        for name, function in self._original.items():
            setattr(feature_restore, name, function)
        noise_estimate.estimate_noise = self._estimate

    def _recording(self, name):
        def step(stage_set, mask, value):
            result = self._original[name](stage_set, mask, value)
            self.steps.setdefault("set", stage_set.copy())
            self.steps.setdefault("kept", mask.copy())
            self.steps[name] = result.copy()
            return result
        return step

    def _estimating(self, stage_set, kept, resolution, side):
        estimate = self._estimate(stage_set, kept, resolution, side)
        self.estimates[side] = estimate
        if side == "dents" and self.foreground_estimate is not None:
            return self.foreground_estimate
        return estimate

    def cropped(self, name, noisy):
        """A recorded mask on the input's grid (the stages run on a cropped, padded box)."""
        offset = np.argwhere(self.steps["set"]).min(axis=0) - np.argwhere(noisy).min(axis=0)
        return self.steps[name][tuple(slice(o, o + s) for o, s in zip(offset, noisy.shape))]


class LargeBallsKept:
    """The pruning keeps every skeleton ball of radius over ``radius`` voxels, whatever its importance."""

    def __init__(self, radius):
        self.radius, self._original = radius, pruning_rules.kept_voxels

    def __enter__(self):
        def kept_voxels(measures, params, joined=None):
            kept, rho_plus = self._original(measures, params, joined=joined)
            return kept | (measures.radius > self.radius), rho_plus
        pruning_rules.kept_voxels = kept_voxels
        return self

    def __exit__(self, *exc):
        pruning_rules.kept_voxels = self._original


def closing(mask, radius):
    pad = int(radius) + 2
    grown = ndimage.distance_transform_edt(~np.pad(mask, pad)) <= radius
    return (ndimage.distance_transform_edt(grown) > radius)[pad:-pad, pad:-pad, pad:-pad]


def variants(case, median):
    """(label, output mask) for every variant of the module's docstring."""
    noisy = case.noise.noisy
    params = DenoiseParams(resolution=case.resolution, fine_pass="off")
    with Recorder() as record:
        default = pipeline.denoise_volume(noisy, params).mask
    yield f"default ({record.estimates['bumps'].describe()})", default
    kept = record.cropped("kept", noisy)
    yield "pruned", kept
    restored = kept | record.cropped("features_by_extent", noisy)
    yield "restored by extent", restored
    restored = kept | record.cropped("along_lines", noisy)
    yield "... but for straight runs' noise", restored
    for radius in (12, 5):
        with LargeBallsKept(radius):
            yield f"balls over {radius} voxels kept", pipeline.denoise_volume(noisy, params).mask
    removed = noisy & ~default
    for sigma, level in ((2.0, 0.7), (3.0, 0.6)):
        reading = ndimage.gaussian_filter(noisy.astype(np.float32), sigma) >= level
        yield f"halo g{sigma}@{level}", default | (removed & reading)
    for radius in (3, 8):
        yield f"closing {radius}", default | closing(default, radius)
    with Recorder() as record:
        record.foreground_estimate = None
        both = pipeline.denoise_volume(noisy, params.with_(stages="both")).mask
    yield f"both stages ({record.estimates['dents'].describe()})", both
    with Recorder() as record:
        with Recorder() as first:
            pipeline.denoise_volume(noisy, params)
        record.foreground_estimate = first.estimates["bumps"]
        yield "background, foreground estimate", pipeline.denoise_volume(noisy, params.with_(stages="both")).mask
    for sigma in (2.0, 3.0):
        reading = ndimage.gaussian_filter(noisy.astype(np.float32), sigma) >= 0.5
        yield f"proxy g{sigma}", ball_owners.seam_smoothed(noisy, oracle.owned_oracle(noisy, reading))
    if median:
        signed = (ndimage.distance_transform_edt(noisy) - ndimage.distance_transform_edt(~noisy)).astype(np.float32)
        for width in (7, 11):
            reading = ndimage.median_filter(signed, size=width) > 0
            yield f"median {width}", reading
            yield f"proxy median {width}", ball_owners.seam_smoothed(noisy, oracle.owned_oracle(noisy, reading))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--shapes", nargs="+", default=["cube", "fandisk", "bunny", "mug"],
                        choices=sorted(shapes.SHAPES))
    parser.add_argument("--kinds", nargs="+", default=["bumps-dents", "stripes"], choices=sorted(quality.NOISE_KINDS))
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--resolution", type=int, default=160)
    parser.add_argument("--median", action="store_true", help="also the median-filtered readings (minutes per case)")
    args = parser.parse_args(argv)
    print("| case | variant | " + " | ".join(title for title, _ in COLUMNS) + " |\n|" + "---|" * (len(COLUMNS) + 2))
    for shape in args.shapes:
        for kind in args.kinds:
            case = Case(shape, kind, args.seed, args.resolution)
            for label, out in [("input", case.noise.noisy), *variants(case, args.median)]:
                cells = " | ".join("–" if np.isnan(v) else f"{v:.3f}" for v in case.scores(out))
                print(f"| {shape} {kind} | {label} | {cells} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
