"""The thesis' tables, re-run: ``python -m benchmarks.thesis_tables TABLE [--resolution N] [--out DIR]``.

TABLE is one of 4.1 (velocity fields), fig4.4 (total skeleton error against t), 5.1 (derivative, direct and
global streamline pruning), 6.1 and 6.2 (EDT filters), 7.1 (geodesic estimate), 8.1 (resolution and time),
fig7.6 (reverse EDT against naive ball splatting) or all. Each prints the thesis' numbers beside ours in the
thesis' layout, with the model, the resolution and the noise used, and writes a figure where the thesis has
one. The thesis' models we do not have are replaced by the nearest shapes of ``benchmarks/shapes.py``, and
labelled as substitutes. The thesis' noise draws and grids are unknown, so what to compare is the ranking and
the magnitude, not the digits (``docs/thesis-tables.md``).
"""

import argparse
import os
import sys
import time

import numpy as np
from scipy import ndimage

from benchmarks import shapes
from skelfilter.core import importance, pipeline, reconstruct, skeleton, stage
from skelfilter.core.decision import pruning_rules
from skelfilter.core.distance import distance_and_features
from skelfilter.core.synthetic_noise import add_noise
from skelfilter.evaluation.metrics import thesis_measures
from skelfilter.mesh.voxelize import voxelize
from skelfilter.params import DenoiseParams
from skelfilter.presets import RHO_RULE_CAP_FACTOR
from skelfilter.runtime.progress import Progress

HERE = os.path.dirname(os.path.abspath(__file__))

# The thesis' model -> the shape standing in for it ("" where it is the same model).
SUBSTITUTES = {"cube": "", "bunny": "", "fandisk": "", "bear": "spot", "cat": "quadruped", "chair": "chair",
               "pot": "mug", "hammer": "l-bracket", "shark": "airplane", "horse": "quadruped"}
PAD = 12

# The thesis' numbers, as printed.
THESIS_4_1 = {  # nu, epsilon for grad rho, unified, feature, grad D
    "cube": ((0.2506, 0.2655), (0.1565, 0.1726), (0.1523, 0.1686), (0.1556, 0.1718)),
    "bunny": ((0.5094, 0.5621), (0.1840, 0.3893), (0.1715, 0.3820), (0.1689, 0.3835)),
    "fandisk": ((0.5708, 0.6057), (0.2904, 0.3741), (0.2751, 0.3684), (0.2768, 0.3666)),
}
THESIS_5_1 = {  # nu, epsilon for derivative (4.2), streamlines (5.2), global (5.6)
    "bear": ((0.0139, 0.6362), (0.0136, 0.6393), (0.0137, 0.6370)),
    "bunny": ((0.0197, 0.6201), (0.0192, 0.6219), (0.0194, 0.6203)),
    "cat": ((0.0185, 0.6268), (0.0175, 0.6337), (0.0180, 0.6291)),
    "chair": ((0.1228, 0.1911), (0.1181, 0.2213), (0.1181, 0.1859)),
    "fandisk": ((0.0327, 0.4538), (0.0330, 0.4556), (0.0319, 0.4563)),
    "cube": ((0.1174, 0.1264), (0.1176, 0.1258), (0.1152, 0.1233)),
    "pot": ((0.0085, 0.6791), (0.0084, 0.6797), (0.0084, 0.6794)),
}
KERNELS_6_1 = ("mean", "minify", "opening", "median")
THESIS_6_1 = {  # implicit, explicit for mean, minify, opening, median
    "bear": (0.0325, 0.0129, 0.0758, 0.1151, 0.0481, 0.0145, 0.0359, 0.0134),
    "bunny": (0.0272, 0.0161, 0.0702, 0.1032, 0.0366, 0.0154, 0.0305, 0.0171),
    "cat": (0.0479, 0.0268, 0.0862, 0.1162, 0.0749, 0.0294, 0.0509, 0.0276),
    "chair": (0.0516, 0.0489, 0.0132, 0.1906, 0.1015, 0.0453, 0.0736, 0.0499),
    "fandisk": (0.0184, 0.0183, 0.0216, 0.0955, 0.0305, 0.0151, 0.0245, 0.0190),
    "hammer": (0.0734, 0.0329, 0.0557, 0.1835, 0.1314, 0.0279, 0.0856, 0.0368),
    "cube": (0.0076, 0.0171, 0.0008, 0.0715, 0.0002, 0.0141, 0.0242, 0.0170),
    "pot": (0.0097, 0.0047, 0.0277, 0.0306, 0.0100, 0.0043, 0.0130, 0.0047),
}
FILTERS_6_2 = ("minify", "explicit-mean", "explicit-opening", "explicit-median", "least-squares", "flat")
THESIS_6_2 = {
    "bear": (0.0758, 0.0129, 0.0145, 0.0134, 0.0364, 0.1354),
    "bunny": (0.0702, 0.0161, 0.0154, 0.0171, 0.0354, 0.1092),
    "cat": (0.0862, 0.0268, 0.0294, 0.0276, 0.0496, 0.1776),
    "chair": (0.0132, 0.0489, 0.0453, 0.0499, 0.0906, 0.1107),
    "fandisk": (0.0216, 0.0183, 0.0151, 0.0190, 0.0456, 0.0569),
    "hammer": (0.0557, 0.0329, 0.0279, 0.0368, 0.0606, 0.1809),
    "cube": (0.0008, 0.0171, 0.0141, 0.0170, 0.0386, 0.0095),
    "pot": (0.0277, 0.0047, 0.0043, 0.0047, 0.0202, 0.0433),
}
THESIS_7_1 = {"shark": (0.0786, 0.8414), "bear": (0.0636, 0.5432), "bunny": (0.0781, 0.8122),
              "cat": (0.0729, 0.7314), "chair": (0.2471, 0.7747), "fandisk": (0.1234, 0.8109),
              "hammer": (0.1188, 0.5818), "cube": (0.1169, 0.2884), "pot": (0.0484, 0.3830)}
THESIS_8_1 = {"shark": (420, 70.54), "bear": (276, 86.30), "bunny": (216, 132.13), "cat": (420, 145.23),
              "chair": (420, 231.64), "fandisk": (276, 681.30), "hammer": (520, 52.34), "cube": (148, 42.34),
              "pot": (276, 271.83)}
# The noise of each experiment (thesis §7.2 parameters), as the thesis gives it; Table 4.1's is not given
# (decision: the noise model's defaults, the 1-D stripes of the qualitative comparison of §4.4).
VELOCITIES = (("grad rho (4.6)", "importance-gradient"), ("unified (4.10)", "unified"), ("feature (4.16)", "feature"),
              ("grad D (4.7)", "edt-gradient"))
NOISE_4_1 = {"p": 0.014, "r": 2.1, "h": 3, "l": 6}
NOISE_5_1 = {"p": 0.001, "r": 3.0, "h": 2, "l": 50}
NOISE_6 = {"p": 0.014, "r": 2.1, "h": 3, "l": 1}
NOISE_8_1 = {"p": 0.02, "r": 2.1, "h": 3, "l": 6}


def grid(model, resolution):
    """The resolution to run ``model`` at: the one given, else the thesis' own for it (Table 8.1). The
    thresholds (t = 18-20, r = 3) are in voxels, so a coarser grid prunes relatively more of the shape."""
    return resolution or THESIS_8_1[model][0]


def label(model, resolution):
    stand_in = SUBSTITUTES[model]
    name = model if not stand_in else f"{model} (substitute: {stand_in})"
    return f"{name}, {grid(model, resolution)}³"


def grids(resolution):
    return f"{resolution}³" if resolution else "the thesis' per model (Table 8.1)"


def clean_volume(model, resolution):
    return voxelize(shapes.load(SUBSTITUTES[model] or model), resolution, PAD)[0]


def noisy_volume(model, resolution, noise, seed=1):
    clean = clean_volume(model, resolution)
    return clean, add_noise(clean, seed=seed, **noise).noisy


STAGE_PAD = 24  # one padding for every threshold, so that the runs of one table share their importance


def stage_params(volume, **params):
    """The thesis preset's foreground stage, for ``volume`` padded by `STAGE_PAD`."""
    return DenoiseParams(preset="thesis", stages="foreground", resolution=max(volume.shape), padding=STAGE_PAD,
                         **params)


def clean_skeleton(clean):
    """The unpruned IE skeleton of the clean shape, in the padded grid (the ground truth S of eq. 4.17)."""
    return skeleton.ie_skeleton(distance_and_features(np.pad(clean, STAGE_PAD))[0])


def skeleton_errors(clean, noisy, variants):
    """(nu, epsilon, near) for the skeleton of ``noisy`` regularised by each of ``variants`` (dicts of
    parameters): eq. 4.18 and 4.17 against the clean skeleton S, and the share of the false positives that
    lie within sqrt(2) voxels of S (S displaced by the noise rather than ligature). The skeleton and its
    importance are computed once for the variants that share them."""
    volume = np.pad(noisy, STAGE_PAD)
    truth = clean_skeleton(clean)
    in_truth = np.zeros(volume.size, dtype=bool)
    in_truth[truth] = True
    near_truth = ndimage.distance_transform_edt(~in_truth.reshape(volume.shape)).reshape(-1) <= np.sqrt(2) + 1e-6
    progress = Progress(enabled=False)
    computed = {}
    errors = []
    for variant in variants:
        p = stage_params(noisy, edt_filter="none", **variant)
        key = (p.skeleton, p.usm_smoothing, p.usm_min_density, p.importance, pruning_rules.search_cap(p))
        if key not in computed:
            computed = {key: stage.skeleton_fields(volume, p, progress)}  # one at a time: they are large
        result = stage.pruned_stage(volume, computed[key].copy(), p, progress).skeleton
        kept = result.voxels[result.kept]
        false = kept[~in_truth[kept]]
        errors.append((thesis_measures.skeleton_false_positive_rate(kept, truth),
                       thesis_measures.skeleton_error(kept, truth), near_truth[false].mean() if len(false) else 1.0))
    return errors


def table_4_1(resolution, out):
    print(f"Table 4.1: skeleton error of the derivative pipeline (eq. 4.4, t = 20) per velocity field; "
          f"resolution {grids(resolution)}, noise {NOISE_4_1}, seed 1. Columns nu / epsilon, ours | thesis.\n")
    print("| model | " + " | ".join(name for name, _ in VELOCITIES) + " |")
    print("|---|" + "---|" * len(VELOCITIES))
    near = []
    for model in ("cube", "bunny", "fandisk"):
        clean, noisy = noisy_volume(model, grid(model, resolution), NOISE_4_1)
        errors = skeleton_errors(clean, noisy, [{"threshold": 20.0, "pruning": "derivative", "velocity": velocity}
                                                for _, velocity in VELOCITIES])
        cells = [f"{nu:.4f} / {eps:.4f} \\| {thesis[0]:.4f} / {thesis[1]:.4f}"
                 for (nu, eps, _), thesis in zip(errors, THESIS_4_1[model])]
        print(f"| {label(model, resolution)} | " + " | ".join(cells) + " |", flush=True)
        near.append(f"{model} " + " / ".join(f"{share:.3f}" for _, _, share in errors))
    print("\nShare of the false positives within sqrt(2) voxels of S, per field: " + "; ".join(near))


def figure_4_4(resolution, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    thresholds = np.arange(4, 41, 4)
    clean, noisy = noisy_volume("fandisk", grid("fandisk", resolution), NOISE_4_1)
    print(f"Fig. 4.4: epsilon (eq. 4.17) against t on fandisk, derivative pipeline (eq. 4.4); resolution "
          f"{grid('fandisk', resolution)}, noise {NOISE_4_1}, seed 1.\n")
    print("| t | " + " | ".join(str(t) for t in thresholds) + " |")
    print("|---|" + "---|" * len(thresholds))
    figure, axes = plt.subplots(figsize=(5, 3.5))
    cap = RHO_RULE_CAP_FACTOR * float(thresholds.max())  # one cap for every t, so that all share one importance
    runs = skeleton_errors(clean, noisy, [{"threshold": float(t), "pruning": "derivative", "velocity": velocity,
                                           "geodesic_cap": cap} for _, velocity in VELOCITIES for t in thresholds])
    for i, (name, _) in enumerate(VELOCITIES):
        errors = [eps for _, eps, _ in runs[i * len(thresholds):(i + 1) * len(thresholds)]]
        print(f"| {name} | " + " | ".join(f"{e:.4f}" for e in errors) + " |", flush=True)
        axes.plot(thresholds, errors, marker="o", label=name)
    # Eq. 4.4 keeps rho >= t only, so no field can keep the voxels of S whose clean rho is below t.
    clean_rho = stage.skeleton_fields(np.pad(clean, STAGE_PAD), stage_params(clean, geodesic_cap=cap),
                                      Progress(enabled=False)).rho  # on the IE skeleton of the clean shape: S
    bound = [1.0 - float(np.mean(clean_rho >= t)) for t in thresholds]
    print("| least epsilon: S with clean rho < t | " + " | ".join(f"{e:.4f}" for e in bound) + " |")
    axes.plot(thresholds, bound, linestyle="--", color="grey", label="S with clean rho < t")
    axes.set_xlabel("t (voxels)")
    axes.set_ylabel("epsilon (eq. 4.17)")
    axes.set_title("fandisk: total skeleton error against t")
    axes.legend()
    figure.tight_layout()
    path = os.path.join(out, "thesis-fig-4-4.png")
    figure.savefig(path, dpi=120)
    print(f"\nwrote {path}")


def table_5_1(resolution, out):
    rules = (("derivative (4.2)", "derivative"), ("streamlines (5.2)", "direct"), ("global (5.6)", "global"))
    print(f"Table 5.1: skeleton error with curvilinear noise, t = 18; resolution {grids(resolution)}, noise "
          f"{NOISE_5_1}, seed 1. Columns nu / epsilon, ours | thesis.\n")
    print("| model | " + " | ".join(name for name, _ in rules) + " |")
    print("|---|" + "---|" * len(rules))
    near = []
    for model, thesis in THESIS_5_1.items():
        clean, noisy = noisy_volume(model, grid(model, resolution), NOISE_5_1)
        errors = skeleton_errors(clean, noisy, [{"threshold": 18.0, "pruning": rule} for _, rule in rules])
        cells = [f"{nu:.4f} / {eps:.4f} \\| {t_nu:.4f} / {t_eps:.4f}"
                 for (nu, eps, _), (t_nu, t_eps) in zip(errors, thesis)]
        print(f"| {label(model, resolution)} | " + " | ".join(cells) + " |", flush=True)
        near.append(f"{model} " + " / ".join(f"{share:.3f}" for _, _, share in errors))
    print("\nShare of the false positives within sqrt(2) voxels of S, per rule: " + "; ".join(near))


def reconstruction_errors(model, resolution, edt_filters):
    """Eq. 6.5 for the foreground stage's reconstruction of the noisy ``model`` under each EDT filter (one
    skeleton and importance for all)."""
    clean, noisy = noisy_volume(model, resolution, NOISE_6)
    volume = np.pad(noisy, STAGE_PAD)
    inner = (slice(STAGE_PAD, -STAGE_PAD),) * 3
    progress = Progress(enabled=False)
    fields = stage.skeleton_fields(volume, stage_params(noisy), progress)
    errors = []
    for edt_filter in edt_filters:
        mask = stage.pruned_stage(volume, fields.copy(), stage_params(noisy, edt_filter=edt_filter), progress).mask
        errors.append(thesis_measures.reconstruction_error(mask[inner], clean))
    return errors


def table_6_1(resolution, out):
    print(f"Table 6.1: reconstruction error (eq. 6.5) of the implicit and explicit kernel filters, r = 3, global "
          f"streamlines, t = 18; resolution {grids(resolution)}, noise {NOISE_6}, seed 1. Cells ours | thesis.\n")
    print("| model | " + " | ".join(f"{k} im. | {k} ex." for k in KERNELS_6_1) + " |")
    print("|---|" + "---|" * (2 * len(KERNELS_6_1)))
    for model, thesis in THESIS_6_1.items():
        names = [name for kernel in KERNELS_6_1 for name in (kernel, f"explicit-{kernel}")]
        errors = reconstruction_errors(model, grid(model, resolution), names)
        cells = [f"{error:.4f} \\| {t:.4f}" for error, t in zip(errors, thesis)]
        print(f"| {label(model, resolution)} | " + " | ".join(cells) + " |", flush=True)


def table_6_2(resolution, out):
    print(f"Table 6.2: reconstruction error (eq. 6.5) of the most relevant EDT filters, r = 3; resolution "
          f"{grids(resolution)}, noise {NOISE_6}, seed 1. Cells ours | thesis.\n")
    print("| model | " + " | ".join(FILTERS_6_2) + " |")
    print("|---|" + "---|" * len(FILTERS_6_2))
    for model, thesis in THESIS_6_2.items():
        errors = reconstruction_errors(model, grid(model, resolution), FILTERS_6_2)
        cells = [f"{error:.4f} \\| {t:.4f}" for error, t in zip(errors, thesis)]
        print(f"| {label(model, resolution)} | " + " | ".join(cells) + " |", flush=True)


SAMPLE_7_1 = 4_000  # skeleton voxels drawn per model: exact geodesics across thin walls go round the rim


def table_7_1(resolution, out):
    print(f"Table 7.1: error of the geodesic estimate (eq. 7.22) against the graph geodesic, IE skeleton of the "
          f"clean model, over {SAMPLE_7_1} of its voxels drawn at random (seed 0); resolution {grids(resolution)}. "
          "Columns mean epsilon (7.23) / maximum m (7.24), ours | thesis.\n")
    print("| model | epsilon | m |")
    print("|---|---|---|")
    rng = np.random.default_rng(0)
    for model, (t_eps, t_m) in THESIS_7_1.items():
        volume = np.pad(clean_volume(model, grid(model, resolution)), 2)
        distance, features = distance_and_features(volume)
        voxels = skeleton.ie_skeleton(distance)
        voxels = np.sort(rng.choice(voxels, min(SAMPLE_7_1, len(voxels)), replace=False))
        a, b = skeleton.extended_feature_points(volume, features, voxels)
        graph, _ = importance.geodesic_importance(importance.boundary_layer(volume), a, b, cap=1e9)
        estimate = importance.geodesic_estimate(distance, a, b)
        valid = graph > 0
        eps, m = thesis_measures.geodesic_errors(graph[valid], estimate[valid])
        print(f"| {label(model, resolution)} | {eps:.4f} \\| {t_eps:.4f} | {m:.4f} \\| {t_m:.4f} |", flush=True)


def table_8_1(resolution, out):
    print(f"Table 8.1: resolution and time of the whole pipeline (--preset thesis, both stages), noise {NOISE_8_1}, "
          "seed 1, at the thesis' resolutions (or --resolution), 2 cores; our time is denoise_volume's, the "
          "thesis' includes reading and writing files.\n")
    print("| model | time ours (s) | time thesis (s) |")
    print("|---|---|---|")
    for model, (_, t_time) in THESIS_8_1.items():
        res = grid(model, resolution)
        _, noisy = noisy_volume(model, res, NOISE_8_1)
        start = time.perf_counter()
        pipeline.denoise_volume(noisy, preset="thesis")
        print(f"| {label(model, resolution)} | {time.perf_counter() - start:.1f} | {t_time:.2f} |", flush=True)


NAIVE_BUDGET = 3e10  # voxel visits of the naive splatting: about a minute


def figure_7_6(resolution, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    res = resolution or 148
    volume = np.pad(clean_volume("cube", res), 2)
    distance, features = distance_and_features(volume)
    voxels = skeleton.ie_skeleton(distance)
    a, b = skeleton.extended_feature_points(volume, features, voxels)
    rho, _ = importance.geodesic_importance(importance.boundary_layer(volume), a, b, cap=1e9)
    radii = distance.reshape(-1)[voxels]
    print(f"Fig. 7.6: reconstruction time against skeleton voxels, cube at {res}³, skeletons regularised by "
          "thresholds on rho that keep 1/2^i of it: reverse EDT (§7.4) against naive ball splatting (eq. 7.25); "
          f"naive runs whose balls add up to more than {NAIVE_BUDGET:.0e} voxel visits are left out. The thesis: "
          "~0.5 s against 1-500 s (~600x).\n")
    print("| skeleton voxels | reverse EDT (s) | naive (s) | same set |")
    print("|---|---|---|---|")
    points = []
    for t in np.quantile(rho, 1.0 - 0.5 ** np.arange(10)):
        keep = rho >= t
        start = time.perf_counter()
        fast = reconstruct.union_of_balls(volume.shape, voxels[keep], radii[keep])[0]
        fast_s = time.perf_counter() - start
        cost = float(((2 * np.ceil(radii[keep]) + 1) ** 3).sum())
        naive_s, same = float("nan"), "–"
        if cost <= NAIVE_BUDGET:
            start = time.perf_counter()
            naive = reconstruct.naive_union_of_balls(volume.shape, voxels[keep], radii[keep])
            naive_s = time.perf_counter() - start
            same = "yes" if np.array_equal(naive, fast) else "no"
        points.append((int(keep.sum()), fast_s, naive_s))
        print(f"| {int(keep.sum())} | {fast_s:.3f} | {naive_s:.2f} | {same} |", flush=True)
    figure, axes = plt.subplots(figsize=(5, 3.5))
    n, fast_s, naive_s = map(np.array, zip(*points))
    axes.semilogy(n, fast_s, marker="o", label="reverse EDT")
    axes.semilogy(n, naive_s, marker="s", label="naive splatting")
    axes.set_xlabel("skeleton voxels")
    axes.set_ylabel("seconds")
    axes.set_title(f"cube {res}³: reconstruction time")
    axes.legend()
    figure.tight_layout()
    path = os.path.join(out, "thesis-fig-7-6.png")
    figure.savefig(path, dpi=120)
    print(f"\nwrote {path}")


TABLES = {"4.1": table_4_1, "fig4.4": figure_4_4, "5.1": table_5_1, "6.1": table_6_1, "6.2": table_6_2,
          "7.1": table_7_1, "8.1": table_8_1, "fig7.6": figure_7_6}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("table", choices=list(TABLES) + ["all"])
    parser.add_argument("--resolution", type=int,
                        help="voxels along the longest side (default: the thesis' own per model, Table 8.1)")
    parser.add_argument("--out", default="thesis-tables-output", help="folder for the figures")
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    for name in TABLES if args.table == "all" else [args.table]:
        start = time.perf_counter()
        TABLES[name](args.resolution, args.out)
        print(f"\n({name}: {time.perf_counter() - start:.0f} s)\n", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
