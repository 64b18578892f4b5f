"""The per-ball oracle (`benchmarks.oracle`), case by case: what a skeleton pipeline could reach if it
knew, ball by ball, which balls are noise; and how well the measures a pipeline has separate the balls
the oracle keeps from the rest.

    python -m experiments.ball_oracle [--shapes NAME ...] [--kinds stripes bumps-dents ...] [--seed 1]
                                     [--resolution 160] [--default] [--seam-sigma 1.0] [--out results.json]

For each case (a benchmark shape, the thesis' noise of `quality.NOISE_KINDS` at ``--resolution``), on
the noise grid, with the clean shape known:

- Labels. Every IE-skeleton ball of the noisy shape, foreground and background (the background
  bounded by the grid's outer layer, as the background stage bounds it), is *noise* where it
  protrudes beyond the clean shape (its radius exceeds the clean distance at its centre, the clean
  shape's for the foreground, its complement's for the background, by more than one voxel), else
  *keep*.
- The oracle's output: the foreground balls whose centre lies inside the clean shape, their radii
  capped at the clean distance, united with the noisy shape's background voxels that no such
  background ball (centre outside the clean shape, radius capped likewise) covers. No stage order,
  one formulation for bumps and dents.
- The owned oracle's output (`owned_oracle`): each voxel decided by the ball that owns it (the ball
  tangent at its nearest boundary point, `ray_owners`): the noisy shape less the voxels owned by
  foreground balls centred outside the clean shape, plus the background voxels owned by background
  balls centred inside it. No radius is capped and no voxel that no dropped ball owns changes, so it has
  no coverage gaps.
- The same, seam smoothed (`seam_smoothed`): the voxels the decision changed, and one voxel around
  them, take the value of the output smoothed by a Gaussian of `SEAM_SIGMA` (the level 1/2); every
  other voxel stays. The one-voxel tunnels and rims that a per-voxel decision leaves where a dropped
  ball meets a kept one close, so the output's genus can equal the clean shape's.
- Their scores, in voxels: bumps left, dents left, noise left (both), clean lost (the clean shape
  outside the dents not in the output), thin parts kept (`metrics.thin_parts`), the voxel error over
  the noisy input's, and the genus of the output against the clean shape's.
- Separability of the foreground balls' labels (protruding; centre outside) by each candidate
  measure of `measures`: the area under the ROC curve (AUC; 0.5 is chance, 1 separates perfectly; a
  measure that is *lower* on noise is turned around).

``--default`` also scores the default pipeline's voxel output (``denoise_volume`` on the noisy mask),
as it is and seam smoothed; ``--seam-sigma`` sets the seam smoothing's Gaussian.
Rows print as they come; a summary per split (tuning shapes, `quality.HELD_OUT`) follows.
"""

import argparse
import json
import sys
import time

import numpy as np
from scipy import ndimage, stats

from benchmarks import oracle, quality, shapes
from skelfilter.core import ball_owners, pipeline, stage
from skelfilter.core.neighbourhood import unravel
from skelfilter.core.reconstruct import union_of_balls
from skelfilter.evaluation import metrics
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.params import DenoiseParams
from skelfilter.runtime.progress import Progress


def auc(values, positive):
    """Area under the ROC curve of ``values`` scoring ``positive`` (Mann-Whitney), at least 0.5
    (a measure that is lower on the positives is turned around)."""
    n_pos, n_neg = int(positive.sum()), int((~positive).sum())
    if n_pos == 0 or n_neg == 0:
        return float("nan")
    ranks = stats.rankdata(values)
    area = (ranks[positive].sum() - n_pos * (n_pos + 1) / 2) / (n_pos * n_neg)
    return float(max(area, 1.0 - area))


def signed_distance(mask):
    """Euclidean distance to the complement inside ``mask`` (> 0), minus the distance to ``mask`` outside."""
    return ndimage.distance_transform_edt(mask) - ndimage.distance_transform_edt(~mask)


RADIUS_BINS = (1.5, 2.0, 3.0, 4.0, 6.0, 8.0, 12.0, 16.0, 24.0, 32.0)  # voxels
REFERENCE_SMOOTHING = 2.0  # voxels: sigma of the Gaussian whose 1/2 level is the smooth reference surface


def protrusion_beyond_larger(shape, centres, radii):
    """Voxels each ball stands beyond the union of the balls of a larger radius bin (`RADIUS_BINS`):
    ``r - sd(c)``, ``sd`` the signed distance to that union; the additive scale-axis coverage (a ball is
    covered by the larger balls grown by its protrusion)."""
    out = np.empty(len(radii))
    edges = (0.0, *RADIUS_BINS, np.inf)
    for lo, hi in zip(edges[:-1], edges[1:]):
        here = (radii >= lo) & (radii < hi)
        if not here.any():
            continue
        larger = radii >= hi
        if not larger.any():
            out[here] = 2 * radii[here]
            continue
        union = union_of_balls(shape, centres[larger], radii[larger])[0]
        out[here] = radii[here] - signed_distance(union).reshape(-1)[centres[here]]
    return out


def measures(noisy, fg, resolution):
    """Per-ball candidate measures of the foreground balls ``fg`` (`oracle.labelled_balls`): name -> array."""
    centres, radii = fg[0], fg[1]
    params = DenoiseParams(resolution=resolution)
    fields = stage.skeleton_fields(noisy, params, Progress(enabled=False))
    a_flat, b_flat = fields.a_flat, fields.b_flat
    data = stage.pruned_stage(noisy, fields.copy(), params, Progress(enabled=False)).skeleton
    order = np.searchsorted(data.voxels, centres)
    found = data.voxels[np.minimum(order, len(data.voxels) - 1)] == centres
    assert found.all(), "the oracle's balls are the stage's skeleton"
    take = lambda values: values[order].astype(np.float64)  # noqa: E731
    rho = take(data.rho)
    feature_span = np.linalg.norm(unravel(a_flat, noisy.shape) - unravel(b_flat, noisy.shape), axis=1)
    reference = ndimage.gaussian_filter(noisy.astype(np.float32), REFERENCE_SMOOTHING) >= 0.5
    beyond_larger = protrusion_beyond_larger(noisy.shape, centres, radii)
    height = radii - signed_distance(reference).reshape(-1)[centres]
    return {
        "rho": rho, "radius": radii, "rho_over_radius": rho / radii,
        "rho_plus": take(data.rho_plus), "sigma_bar": np.nan_to_num(take(data.sigma_bar), nan=-1.0),
        "lambda": take(feature_span) / 2,
        "beyond_larger": beyond_larger, "beyond_larger_over_radius": beyond_larger / radii,
        "height_above_smooth": height,
    }


def separability(noisy, fg, resolution):
    """AUC of every candidate measure (`measures`) on the foreground balls' two labels: protruding more
    than `oracle.PROTRUSION` beyond the clean shape (``auc``), and centred outside it (``auc_outside``: the balls
    the oracle drops; the others it keeps with their radius capped)."""
    values = measures(noisy, fg, resolution)
    outside = fg[2] <= 0
    return ({name: auc(v, fg[3]) for name, v in values.items()},
            {name: auc(v, outside) for name, v in values.items()})


def scores(out, noise, thin):
    """The voxel measures of an output mask against the case's noise masks (`quality.voxel_measures`)
    and the genus of its voxels."""
    return {**quality.voxel_measures(out, noise, thin), "genus": metrics.voxel_genus(out)["genus"]}


def run_case(shape, kind, seed, resolution, with_default, seam_sigma=ball_owners.SEAM_SIGMA):
    case = quality.Case(shape, kind, seed)
    _, noise, _ = mesh_pipeline.noisy_mesh(shapes.load(shape), case.noise(resolution))
    thin = metrics.thin_parts(noise.clean, quality.THIN_RADIUS)
    start = time.perf_counter()
    out, fg = oracle.oracle(noise.noisy, noise.clean)
    row = {"case": case.name, "split": case.split, "oracle_s": time.perf_counter() - start,
           "clean_genus": metrics.voxel_genus(noise.clean)["genus"], "balls": int(len(fg[0])),
           "noise_balls": int(fg[3].sum()), "oracle": scores(out, noise, thin),
           "outside_balls": int((fg[2] <= 0).sum())}
    start = time.perf_counter()
    owned = oracle.owned_oracle(noise.noisy, noise.clean)
    row["owned_s"] = time.perf_counter() - start
    row["owned"] = scores(owned, noise, thin)
    row["seam"] = scores(ball_owners.seam_smoothed(noise.noisy, owned, seam_sigma), noise, thin)
    row["auc"], row["auc_outside"] = separability(noise.noisy, fg, resolution)
    if with_default:
        mask = pipeline.denoise_volume(noise.noisy, DenoiseParams(resolution=resolution)).mask
        row["default"] = scores(mask, noise, thin)
        row["default_seam"] = scores(ball_owners.seam_smoothed(noise.noisy, mask, seam_sigma), noise, thin)
    return row


def _scored(name, o, clean_genus):
    return (f"{name}: noise left {o['noise_left']:.3f} (bumps {o['bumps_left']:.3f}, dents {o['dents_left']:.3f}), "
            f"clean lost {100 * o['clean_lost']:.2f} %, thin kept {o['thin_kept']:.3f}, error ratio "
            f"{o['error_ratio']:.3f}, genus {o['genus']} (clean {clean_genus})")


def _line(row):
    g = row["clean_genus"]
    text = (f"{row['case']:28s} {row['split']:9s} " + _scored("oracle", row["oracle"], g)
            + f", {row['oracle_s']:.1f} s | " + _scored("owned oracle", row["owned"], g) + f", {row['owned_s']:.1f} s"
            + " | " + _scored("seam smoothed", row["seam"], g)
            + " | AUC " + ", ".join(f"{name} {value:.3f}" for name, value in row["auc"].items())
            + f" ({row['noise_balls']} of {row['balls']} balls noise) | AUC centre outside "
            + ", ".join(f"{name} {value:.3f}" for name, value in row["auc_outside"].items())
            + f" ({row['outside_balls']} balls)")
    if "default" in row:
        text += (" | " + _scored("default", row["default"], g)
                 + " | " + _scored("default, seam smoothed", row["default_seam"], g))
    return text


def _median(rows, *keys):
    values = []
    for row in rows:
        for key in keys:
            row = row[key]
        values.append(row)
    return float(np.nanmedian(values))


def summary(rows):
    lines = []
    for split in quality.SPLITS:
        part = [r for r in rows if r["split"] == split]
        if not part:
            continue
        outputs = ["oracle", "owned", "seam"]
        if all("default" in r for r in part):
            outputs += ["default", "default_seam"]
        text = f"{split} ({len(part)} cases), medians: " + "; ".join(
            f"{name} noise left {_median(part, name, 'noise_left'):.3f}, clean lost "
            f"{100 * _median(part, name, 'clean_lost'):.2f} %, thin kept {_median(part, name, 'thin_kept'):.3f}, "
            f"error ratio {_median(part, name, 'error_ratio'):.3f}, genus {_median(part, name, 'genus'):.0f}, "
            f"genus equal to the clean shape's on {sum(r[name]['genus'] == r['clean_genus'] for r in part)} "
            f"of {len(part)}" for name in outputs)
        text += ("; AUC medians " + ", ".join(f"{name} {_median(part, 'auc', name):.3f}" for name in part[0]["auc"])
                 + "; AUC medians, centre outside: "
                 + ", ".join(f"{name} {_median(part, 'auc_outside', name):.3f}" for name in part[0]["auc"]))
        lines.append(text)
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--shapes", nargs="+", default=sorted(shapes.SHAPES), choices=sorted(shapes.SHAPES))
    parser.add_argument("--kinds", nargs="+", default=["stripes", "bumps-dents"], choices=sorted(quality.NOISE_KINDS))
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--resolution", type=int, default=160)
    parser.add_argument("--default", action="store_true", help="also score the default pipeline's voxel output")
    parser.add_argument("--seam-sigma", type=float, default=ball_owners.SEAM_SIGMA,
                        help="voxels: the Gaussian of the seam smoothing (`ball_owners.seam_smoothed`)")
    parser.add_argument("--out", help="also write every row as JSON here")
    args = parser.parse_args(argv)
    rows = []
    for shape in args.shapes:
        for kind in args.kinds:
            rows.append(run_case(shape, kind, args.seed, args.resolution, args.default, args.seam_sigma))
            print(_line(rows[-1]), flush=True)
    for line in summary(rows):
        print(line)
    if args.out:
        with open(args.out, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
