"""An experiment: how far a learned per-ball decision gets towards the per-ball oracle (`ball_oracle`).

    pip install scikit-learn     # the experiment's own need; skelfilter does not depend on it
    python -m experiments.learned_ball_decision features --cases fandisk:stripes ... [--heights 2 3 5] [--dir FOLDER]
    python -m experiments.learned_ball_decision train [--dir FOLDER]
    python -m experiments.learned_ball_decision evaluate --cases gear:stripes ... [--thresholds 0.5 0.8] [--dir FOLDER]

``features`` writes, per case (a benchmark shape and a noise kind of `quality.NOISE_KINDS`, seed 1,
160 voxels), every IE-skeleton ball of both sides of the noisy shape (foreground; the background
bounded by the grid's outer layer) with its measures: D, rho, rho+, sigma_bar, lambda (half the span of
its two feature points), whether the default's pruning keeps it, the signed distance of its centre to
the default's pruned reconstruction and to the noisy shape smoothed by Gaussians of 1, 2 and 3 voxels,
the noise estimate's height; and its labels: the clean distance at its centre (the ball is *dropped*
by the oracle where it is 0). A case's shape is a benchmark shape or ``procedural-SEED``
(`shapes.procedural`: a body with rods and plates 2-8 voxels thick); ``--heights`` writes one file per
noise height replacing the kind's h. The kind ``clean`` is the shape without noise (every ball kept):
in training it shows the model clean thin parts; in evaluating it measures what the decision does to
an input that needs nothing.

``train`` fits gradient-boosted trees on every case found in ``--dir`` but the held-out shapes' and
the ``high`` noise's (kept for evaluating on a noise never trained on) and ``--leave-out``'s shapes
(to measure, on tuning shapes, what the model does on a shape it never saw), into ``--model-dir``: a
classifier of dropped balls and a regressor of the clean radius (the oracle's cap) of the others. ``--weigh voxels``
weighs each ball by the voxels it owns (`ball_owners.ray_owners`), so that the loss counts voxels, not
balls.

``--context`` adds to a ball's inputs its skeleton neighbourhood's (`context`: mean and largest radius,
mean heights, 3 and 8 steps along the skeleton; the steps to the nearest thick ball), for train and
evaluate alike; ``--context course`` adds how the skeleton runs there too (`course`: whether it
follows a line or a sheet, and how far the ball lies off them).

``evaluate`` prints, per case, the classifier's AUC on each side and the scores (`ball_oracle.scores`)
of the outputs the model gives: the owned output (`ball_owners.owned_output`: the voxels of dropped
balls flip), the same with the drop chances averaged over the skeleton (`smoothed_on_skeleton`),
dropped above each of ``--thresholds`` (``--background-threshold``: the background's, where it
differs), that output `rescued`: the noisy shape's voxels that a kept ball covers, its radius capped at
the predicted clean radius, put back on both sides; and both seam smoothed (`ball_owners.seam_smoothed`).
"""

import argparse
import dataclasses
import itertools
import os
import pickle
import sys

import numpy as np
from scipy import ndimage, sparse
from scipy.sparse import csgraph

from benchmarks import quality, shapes
from experiments import ball_oracle
from skelfilter.core import ball_owners, saliency, stage
from skelfilter.core.decision import noise_estimate
from skelfilter.core.neighbourhood import unravel
from skelfilter.core.reconstruct import union_of_balls
from skelfilter.evaluation import metrics
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.params import DenoiseParams
from skelfilter.runtime.progress import Progress

RESOLUTION = 160
SMOOTHING = (1.0, 2.0, 3.0)  # voxels: the Gaussians whose 1/2 level gives reference surfaces
MEASURES = ("r", "rho", "rho_plus", "sigma_bar", "lambda", "kept", "sd_core", "sd_smooth1", "sd_smooth2",
            "sd_smooth3", "noise_height", "noise_found")
THICK_RADII = (3.0, 5.0, 8.0)  # voxels
FAR_STEPS = 60  # skeleton steps: farther from a thick ball counts as this far
CLEAN = "clean"  # the kind of a case without noise: every ball is kept
TRAINING_BALLS = 1_500_000  # drawn at random from the tuning cases


def _case(text):
    shape, _, kind = text.partition(":")
    known_shape = shape in shapes.SHAPES or shape.startswith("procedural-")
    if not known_shape or kind not in (*quality.NOISE_KINDS, CLEAN):
        raise argparse.ArgumentTypeError(f"a case is SHAPE:KIND (SHAPE of the benchmark or procedural-SEED, KIND a "
                                         f"noise kind or {CLEAN}), got {text!r}")
    return shape, kind


def _noise(shape, kind, height=None):
    """The case and its noise; ``height`` replaces the kind's h (voxels); the kind `CLEAN` has none."""
    case = quality.Case(shape, kind, 1)
    if kind == CLEAN:  # any kind's parameters, with no incident sites
        noise = dataclasses.replace(quality.Case(shape, "stripes", 1).noise(RESOLUTION), p=0.0)
    else:
        noise = case.noise(RESOLUTION)
        if height is not None:
            noise = dataclasses.replace(noise, h=height)
    return case, mesh_pipeline.noisy_mesh(shapes.load(shape), noise)[1]


def _file(shape, kind, height=None):
    return f"{shape}_{kind}.npz" if height is None else f"{shape}_{kind}_h{height}.npz"


def side_measures(side, clean_side, estimate_side):
    """The balls of the set ``side``: centres, their measures (name -> array) and clean distances."""
    params = DenoiseParams(resolution=RESOLUTION)
    fields = stage.skeleton_fields(side, params, Progress(enabled=False))
    a_flat, b_flat = fields.a_flat, fields.b_flat
    pruned = stage.pruned_stage(side, fields.copy(), params, Progress(enabled=False))
    data, centres = pruned.skeleton, pruned.skeleton.voxels
    estimate = noise_estimate.estimate_noise(side, pruned.mask, RESOLUTION, estimate_side)
    values = {
        "r": data.distance, "rho": data.rho, "rho_plus": np.nan_to_num(data.rho_plus, nan=-1.0),
        "sigma_bar": np.nan_to_num(data.sigma_bar, nan=-1.0),
        "lambda": np.linalg.norm(unravel(a_flat, side.shape) - unravel(b_flat, side.shape), axis=1) / 2,
        "kept": data.kept, "sd_core": ball_oracle.signed_distance(pruned.mask).reshape(-1)[centres],
        "noise_height": np.full(len(centres), estimate.height if estimate.found else 0.0),
        "noise_found": np.full(len(centres), float(estimate.found)),
    }
    for sigma in SMOOTHING:
        reference = ndimage.gaussian_filter(side.astype(np.float32), sigma) >= 0.5
        values[f"sd_smooth{sigma:g}"] = ball_oracle.signed_distance(reference).reshape(-1)[centres]
    clean_distance = ndimage.distance_transform_edt(clean_side).reshape(-1)[centres]
    return centres, {k: np.asarray(v, dtype=np.float64) for k, v in values.items()}, clean_distance


def _sides(noise):
    bounded = ball_owners.bounded_background
    return (("fg", noise.noisy, noise.clean, "bumps"),
            ("bg", bounded(noise.noisy), bounded(noise.clean), "dents"))


def features(cases, folder, heights=(None,)):
    os.makedirs(folder, exist_ok=True)
    for (shape, kind), height in itertools.product(cases, heights):
        _, noise = _noise(shape, kind, height)
        saved = {"grid_shape": np.array(noise.noisy.shape)}
        for name, side, clean_side, estimate_side in _sides(noise):
            centres, values, clean_distance = side_measures(side, clean_side, estimate_side)
            saved[f"{name}_centres"], saved[f"{name}_clean_d"] = centres, clean_distance
            saved.update({f"{name}_f_{k}": v for k, v in values.items()})
        np.savez_compressed(os.path.join(folder, _file(shape, kind, height)), **saved)
        print("measured", shape, kind, height or "", flush=True)


def _adjacency(centres, grid_shape):
    indptr, indices = saliency.skeleton_adjacency(centres, tuple(grid_shape))
    n = len(centres)
    return sparse.csr_matrix((np.ones(len(indices)), indices, indptr), shape=(n, n)), 1.0 + np.diff(indptr)


def _with_neighbours(values, adjacency, degree):
    """``values`` (one row per ball) averaged with the skeleton neighbours' rows: one step of the
    neighbourhood means of `context`, `course` and `smoothed_on_skeleton`."""
    return (values + adjacency @ values) / (degree if values.ndim == 1 else degree[:, None])


def _neighbour_max(values, adjacency, rounds):
    """The largest of ``values`` within ``rounds`` skeleton steps of each ball."""
    indptr, indices = adjacency.indptr, adjacency.indices
    for _ in range(rounds):
        spread = values.copy()
        rows = np.flatnonzero(np.diff(indptr))
        spread[rows] = np.maximum(values[rows], np.maximum.reduceat(values[indices], indptr[rows]))
        values = spread
    return values


def context(f, centres, grid_shape):
    """Measures of a ball's skeleton neighbourhood (26-adjacent centres, 3 and 8 steps): the mean and
    largest radius, the mean height above the smoothed shape and above the core, and the steps along
    the skeleton to the nearest ball of radius at least each of `THICK_RADII`: whether a small ball
    lies on a rod that goes on beyond the blob it is in, far from the body it hangs on."""
    adjacency, degree = _adjacency(centres, grid_shape)
    columns = []
    for name in ("r", "height2", "height_core"):
        mean = f[name]
        for rounds in range(1, 9):
            mean = _with_neighbours(mean, adjacency, degree)
            if rounds in (3, 8):
                columns.append(mean)
    columns += [_neighbour_max(f["r"], adjacency, 3), _neighbour_max(f["r"], adjacency, 8)]
    for radius in THICK_RADII:
        thick = np.flatnonzero(f["r"] >= radius)
        steps = (csgraph.dijkstra(adjacency, unweighted=True, indices=thick, min_only=True, limit=FAR_STEPS)
                 if len(thick) else np.full(len(centres), np.inf))
        columns.append(np.minimum(steps, FAR_STEPS))
    return columns


def course(centres, grid_shape, rounds=(8, 16)):
    """How the skeleton runs around each ball, over ``rounds`` steps (the centres' positions averaged
    with their skeleton neighbours', as the mean of `context`): the covariance of the positions gives
    linearity and planarity ((l1 - l2) / l1, (l2 - l3) / l1 of its eigenvalues), the spread sqrt(l1),
    and the ball's distance off the line (the principal axis through the mean) and off the plane. A
    leg's ball lies on the line its neighbourhood follows; a blob's on that leg lies off it once the
    neighbourhood reaches beyond the blob (over 8 steps a blob's tip lies on its own branch's line)."""
    adjacency, degree = _adjacency(centres, grid_shape)
    xyz = unravel(centres, tuple(grid_shape)).astype(np.float64)
    mean, second = xyz, (xyz[:, :, None] * xyz[:, None, :]).reshape(-1, 9)
    columns = []
    for step in range(1, max(rounds) + 1):
        mean, second = _with_neighbours(mean, adjacency, degree), _with_neighbours(second, adjacency, degree)
        if step not in rounds:
            continue
        covariance = second.reshape(-1, 3, 3) - mean[:, :, None] * mean[:, None, :]
        values, vectors = np.linalg.eigh(covariance)
        l3, l2, l1 = np.maximum(values, 0).T
        scale = np.maximum(l1, 1e-9)
        offset = xyz - mean
        along = np.einsum("ij,ij->i", offset, vectors[:, :, 2])
        off_line = np.sqrt(np.maximum((offset ** 2).sum(1) - along ** 2, 0))
        off_plane = np.abs(np.einsum("ij,ij->i", offset, vectors[:, :, 0]))
        columns += [(l1 - l2) / scale, (l2 - l3) / scale, np.sqrt(l1), off_line, off_plane]
    return columns


def load(folder, shape, kind, name=None, with_context=None):
    """Per side: (centres, the model's inputs, clean distances, radii); ``name``: the file's, when
    not the case's; ``with_context``: the inputs include `context` (and `course`, where it is
    ``"course"``)."""
    z = np.load(os.path.join(folder, name or _file(shape, kind)))
    out = {}
    for side in ("fg", "bg"):
        f = {n: z[f"{side}_f_{n}"] for n in MEASURES}
        r = f["r"]
        f["height2"], f["height_core"] = r - f["sd_smooth2"], r - f["sd_core"]
        derived = [f["height_core"], f["height2"], r - f["sd_smooth1"], r - f["sd_smooth3"], f["rho"] / r,
                   r / np.maximum(f["noise_height"], 1), np.full(len(r), float(side == "bg"))]
        if with_context:
            derived += context(f, z[f"{side}_centres"], z["grid_shape"])
        if with_context == "course":
            derived += course(z[f"{side}_centres"], z["grid_shape"])
        inputs = np.stack([f[n] for n in MEASURES] + derived, 1).astype(np.float32)
        out[side] = (z[f"{side}_centres"], inputs, z[f"{side}_clean_d"], r)
    return out


def owners(shape, kind, height=None):
    """`ball_owners.ray_owners` of both sides of a case, and the case's noise masks."""
    _, noise = _noise(shape, kind, height)
    return {name: ball_owners.ray_owners(side) for name, side, _, _ in _sides(noise)}, noise


def _model_file(folder, weigh, with_context):
    suffix = {None: "", "neighbourhood": "-context", "course": "-context-course"}[with_context]
    return os.path.join(folder, f"model-{weigh}{suffix}.pkl")


def train(folder, weigh="balls", with_context=None, leave_out=(), model_folder=None):
    from sklearn.ensemble import HistGradientBoostingClassifier, HistGradientBoostingRegressor
    left_out = set(quality.HELD_OUT) | set(leave_out)
    names = sorted(n for n in os.listdir(folder) if n.endswith(".npz") and n.split("_")[0] not in left_out
                   and "_high" not in n)  # the taller noise is held aside as a kind never trained on
    print("training on", ", ".join(n.removesuffix(".npz") for n in names), flush=True)
    parts, weights = [], []
    for name in names:
        shape, kind, *height = name.removesuffix(".npz").split("_")
        height = int(height[0].removeprefix("h")) if height else None
        loaded = load(folder, shape, kind, name, with_context)
        owned = owners(shape, kind, height)[0] if weigh == "voxels" else None
        for side in ("fg", "bg"):
            parts.append(loaded[side])
            if owned is not None:
                _, owner, centres, _ = owned[side]
                assert np.array_equal(centres, loaded[side][0])
                weights.append(1.0 + np.bincount(owner[owner >= 0], minlength=len(centres)))
    inputs = np.concatenate([p[1] for p in parts])
    weight = np.concatenate(weights) if weights else np.ones(len(inputs))
    dropped = np.concatenate([p[2] <= 0 for p in parts])
    cap = np.concatenate([np.minimum(p[2], p[3]) for p in parts])
    pick = np.random.default_rng(0).choice(len(inputs), min(len(inputs), TRAINING_BALLS), replace=False)
    trees = dict(max_iter=200, learning_rate=0.1, max_leaf_nodes=63, random_state=0)
    classifier = HistGradientBoostingClassifier(**trees).fit(inputs[pick], dropped[pick], sample_weight=weight[pick])
    kept = pick[~dropped[pick]]
    regressor = HistGradientBoostingRegressor(**trees).fit(inputs[kept], cap[kept], sample_weight=weight[kept])
    os.makedirs(model_folder or folder, exist_ok=True)
    with open(_model_file(model_folder or folder, weigh, with_context), "wb") as f:
        pickle.dump((classifier, regressor), f)


def rescued(out, parts, dropped, radii, noisy):
    """``out`` with the noisy shape's voxels that a kept ball covers (radius ``radii``, the model's
    clean radius) put back, on both sides: a rod's core balls keep the rod where a dropped noise ball
    owns its voxels."""
    out = out.copy()
    for side, value in (("fg", True), ("bg", False)):
        centres, keep = parts[side][0], ~dropped[side] & (radii[side] > 0)
        covered = union_of_balls(noisy.shape, centres[keep], radii[side][keep])[0]
        out[covered & (noisy == value)] = value
    out[[0, -1], :, :] = out[:, [0, -1], :] = out[:, :, [0, -1]] = False
    return out


def smoothed_on_skeleton(chance, centres, shape, rounds=3):
    """``chance`` (one per ball) averaged with its skeleton neighbours' (26-adjacent centres),
    ``rounds`` times: neighbouring balls of one sheet decided alike."""
    adjacency, degree = _adjacency(centres, shape)
    for _ in range(rounds):
        chance = _with_neighbours(chance, adjacency, degree)
    return chance


def evaluate(cases, folder, weigh="balls", thresholds=(0.5,), with_context=None, background_threshold=None,
             model_folder=None):
    with open(_model_file(model_folder or folder, weigh, with_context), "rb") as f:
        classifier, regressor = pickle.load(f)
    for shape, kind in cases:
        parts = load(folder, shape, kind, with_context=with_context)
        aucs = [ball_oracle.auc(classifier.predict_proba(parts[s][1])[:, 1], parts[s][2] <= 0) for s in ("fg", "bg")]
        owned, noise = owners(shape, kind)
        case = quality.Case(shape, kind, 1)
        thin = metrics.thin_parts(noise.clean, quality.THIN_RADIUS)
        chance = {side: classifier.predict_proba(parts[side][1])[:, 1] for side in ("fg", "bg")}
        dropped = {side: chance[side] >= 0.5 for side in ("fg", "bg")}
        smoothed = {side: smoothed_on_skeleton(chance[side], parts[side][0], noise.noisy.shape)
                    for side in ("fg", "bg")}
        kept_radii = {side: np.minimum(parts[side][3], np.maximum(regressor.predict(parts[side][1]), 0))
                      for side in ("fg", "bg")}
        outputs = {"model, owned": ball_owners.owned_output(noise.noisy, owned["fg"], owned["bg"], dropped["fg"],
                                                            dropped["bg"])}
        for t in thresholds:
            background = t if background_threshold is None else background_threshold
            drop = {"fg": smoothed["fg"] >= t, "bg": smoothed["bg"] >= background}
            out = ball_owners.owned_output(noise.noisy, owned["fg"], owned["bg"], drop["fg"], drop["bg"])
            outputs[f"model, owned, smoothed {t:g}"] = out
            kept = rescued(out, parts, drop, kept_radii, noise.noisy)
            outputs[f"model, owned, smoothed {t:g}, rescued"] = kept
            outputs[f"model, owned, smoothed {t:g}, seam"] = ball_owners.seam_smoothed(noise.noisy, out)
            outputs[f"model, owned, smoothed {t:g}, rescued, seam"] = ball_owners.seam_smoothed(noise.noisy, kept)
        for name, out in outputs.items():
            s = ball_oracle.scores(out, noise, thin)
            print(f"{case.name:24s} {case.split:9s} {name:28s} AUC fg {aucs[0]:.3f} bg {aucs[1]:.3f} | noise left "
                  f"{s['noise_left']:.3f} (bumps {s['bumps_left']:.3f}, dents {s['dents_left']:.3f}), clean lost "
                  f"{100 * s['clean_lost']:.2f} %, thin kept {s['thin_kept']:.3f}, error ratio {s['error_ratio']:.3f}, "
                  f"genus {s['genus']}", flush=True)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("step", choices=("features", "train", "evaluate"))
    parser.add_argument("--cases", nargs="+", type=_case, default=[])
    parser.add_argument("--heights", nargs="+", type=int, default=[None],
                        help="features: noise heights (voxels) replacing each kind's h, one file per height")
    parser.add_argument("--dir", default="learned-ball-decision", help="where measures and the model go")
    parser.add_argument("--weigh", choices=("balls", "voxels"), default="balls",
                        help="train: every ball alike, or each by the voxels it owns (evaluate: the model trained so)")
    parser.add_argument("--thresholds", nargs="+", type=float, default=[0.5],
                        help="evaluate: the smoothed drop chances above which a ball is dropped")
    parser.add_argument("--context", nargs="?", const="neighbourhood", choices=("neighbourhood", "course"),
                        help="train, evaluate: the inputs include each ball's skeleton neighbourhood (`context`); "
                             "course: and how the skeleton runs there (`course`)")
    parser.add_argument("--background-threshold", type=float,
                        help="evaluate: the background's threshold, where it is not the foreground's")
    parser.add_argument("--leave-out", nargs="+", default=[], choices=sorted(shapes.SHAPES),
                        help="train: shapes left out of the training, besides the held-aside ones")
    parser.add_argument("--model-dir", help="train, evaluate: where the model goes (default --dir)")
    args = parser.parse_args(argv)
    if args.step == "features":
        features(args.cases, args.dir, args.heights)
    elif args.step == "train":
        train(args.dir, args.weigh, args.context, args.leave_out, args.model_dir)
    else:
        evaluate(args.cases, args.dir, args.weigh, args.thresholds, args.context, args.background_threshold,
                 args.model_dir)
    return 0


if __name__ == "__main__":
    sys.exit(main())
