"""Volumes with segmentation-like noise: skelfilter against the smoothing a segmentation user has.

    python -m benchmarks.volumes [--resolution 128] [--shapes a,b] [--out volume-output]

A noisy segmentation (a CT or MRI mask thresholded from a noisy image) has bumps, dents, islands and
pits of one to three voxels together. It is made here as the clean shape's signed distance (voxels,
> 0 inside) plus a smooth random field (white noise smoothed by a Gaussian of ``sigma`` voxels,
scaled to a standard deviation of ``amplitude`` voxels), thresholded at 0, at the three strengths of
`STRENGTHS`: weak and strong short noise (sigma 1: islands and pits of 1-3 voxels), and a taller,
smoother one (amplitude 1.25, sigma 1.75: the bumps and dents of a segmentation made from a noisier
image). Each noisy mask goes through skelfilter's presets (`skelfilter.denoise_volume`) and the
baselines of 3D Slicer's smoothing effects: the median over 3x3x3 (Slicer's default) and 5x5x5
voxels, a Gaussian of sigma 1.5 voxels then a threshold at one half, and opening then closing by a
ball of radius 1.

Measured on the case's grid against the clean mask: ``error_ratio`` = |out xor clean| / |noisy xor
clean| (below 1 improves on the input), ``thin_kept`` (`skelfilter.evaluation.metrics.thin_parts`, radius 4)
and the 26-connected ``components`` against the clean mask's. The shapes of ``quality.HELD_OUT`` are
reported apart. Each method also runs on the clean masks: the share of their voxels it changes (a
clean segmentation should pass through). Writes ``results.json`` and ``table.md`` into ``--out``
(``--pictures``: also ``pictures.png``, the surfaces of a few thin-featured cases).
"""

import argparse
import json
import os
import sys
import time

import numpy as np
from scipy import ndimage

from benchmarks import shapes
from skelfilter.core import pipeline
from skelfilter.evaluation import metrics
from skelfilter.mesh.voxelize import grid_for_bounds, voxelize_on_grid

# (the noise field's standard deviation, the Gaussian smoothing of its white noise), voxels
STRENGTHS = {"weak": (0.6, 1.0), "strong": (1.0, 1.0), "smooth": (1.25, 1.75)}
PADDING = 6
SHAPES = ("fandisk", "rocker-arm", "bunny", "block", "u-channel", "airplane", "quadruped", "chair", "spot",
          "l-bracket", "stool")
HELD_OUT = ("spot", "l-bracket", "twelve", "stool", "gear")
CUBE = np.ones((3, 3, 3), dtype=bool)
BALL_1 = ndimage.generate_binary_structure(3, 1)


def clean_mask(shape, resolution):
    mesh = shapes.load(shape)
    return voxelize_on_grid(mesh, grid_for_bounds(mesh.bounds, resolution, PADDING))


def signed_distance(mask):
    """Voxels, > 0 inside: half a voxel at the outermost set voxels' faces."""
    return np.where(mask, ndimage.distance_transform_edt(mask) - 0.5, -(ndimage.distance_transform_edt(~mask) - 0.5))


def segmentation_noise(mask, amplitude, sigma, seed):
    """``mask``'s signed distance plus a random field smoothed at ``sigma`` of standard deviation
    ``amplitude``, > 0."""
    field = ndimage.gaussian_filter(np.random.default_rng(seed).standard_normal(mask.shape), sigma)
    field *= amplitude / field.std()
    return signed_distance(mask) + field > 0


BASELINES = {
    "median 3": lambda m: ndimage.median_filter(m.astype(np.uint8), size=3).astype(bool),
    "median 5": lambda m: ndimage.median_filter(m.astype(np.uint8), size=5).astype(bool),
    "gaussian 1.5": lambda m: ndimage.gaussian_filter(m.astype(np.float32), 1.5) > 0.5,
    "open-close 1": lambda m: ndimage.binary_closing(ndimage.binary_opening(m, BALL_1), BALL_1),
}
VARIANTS = {
    "skelfilter default": {},
    "skelfilter thesis": {"preset": "thesis"},
}


def score(out, clean, noisy, thin):
    return {"error_ratio": float(np.count_nonzero(out ^ clean) / max(np.count_nonzero(noisy ^ clean), 1)),
            "thin_kept": metrics.thin_parts_kept(out, thin),
            "components": int(ndimage.label(out, structure=CUBE)[1])}


def run_case(shape, strength, resolution, seed=1):
    clean = clean_mask(shape, resolution)
    noisy = segmentation_noise(clean, *STRENGTHS[strength], seed)
    thin = metrics.thin_parts(clean)
    row = {"shape": shape, "strength": strength, "split": "held-out" if shape in HELD_OUT else "tuning",
           "clean_components": int(ndimage.label(clean, structure=CUBE)[1]),
           "methods": {"noisy": score(noisy, clean, noisy, thin)}}
    for name, method in BASELINES.items():
        start = time.perf_counter()
        row["methods"][name] = {**score(method(noisy), clean, noisy, thin), "seconds": time.perf_counter() - start}
    for name, overrides in VARIANTS.items():
        start = time.perf_counter()
        try:
            out = pipeline.denoise_volume(noisy, **overrides).mask
        except Exception as exc:  # the method under test: record, measure the rest
            row["methods"][name] = {"error": f"{type(exc).__name__}: {exc}"}
            continue
        row["methods"][name] = {**score(out, clean, noisy, thin), "seconds": time.perf_counter() - start}
    return row


PICTURE_CASES = (("airplane", "strong"), ("chair", "weak"), ("quadruped", "strong"), ("fandisk", "strong"))
PICTURE_METHODS = ("noisy", "median 3", "gaussian 1.5", "skelfilter default", "clean")


def pictures(resolution, path, cases=PICTURE_CASES):
    """Marching-cubes surfaces of the noisy mask, two baselines, the default and the clean mask, one
    row per case, written as a PNG."""
    import matplotlib.pyplot as plt

    from skelfilter.evaluation import camera, figures
    from skelfilter.mesh import marching_cubes
    from skelfilter.mesh.voxelize import Grid

    fig = plt.figure(figsize=(3.2 * len(PICTURE_METHODS), 3.2 * len(cases)), dpi=100)
    for row, (shape, strength) in enumerate(cases):
        clean = clean_mask(shape, resolution)
        noisy = segmentation_noise(clean, *STRENGTHS[strength], 1)
        masks = {"noisy": noisy, "clean": clean, "skelfilter default": pipeline.denoise_volume(noisy).mask,
                 **{name: BASELINES[name](noisy) for name in PICTURE_METHODS if name in BASELINES}}
        grid = Grid(origin=(0.0, 0.0, 0.0), pitch=1.0, shape=clean.shape)
        bounds = None
        for col, name in enumerate(PICTURE_METHODS):
            mesh = marching_cubes.mask_to_mesh(masks[name], grid)
            bounds = mesh.bounds if bounds is None else bounds
            ax = fig.add_subplot(len(cases), len(PICTURE_METHODS), row * len(PICTURE_METHODS) + col + 1,
                                 projection="3d")
            figures.draw_mesh(ax, mesh, camera.direction_from_angles(25, -60), bounds=bounds)
            ax.set_title(f"{shape} {strength}: {name}" if col == 0 else name, fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def clean_pass(shape, resolution):
    """What each method changes on the clean mask itself: the share of its voxels."""
    clean = clean_mask(shape, resolution)
    total = np.count_nonzero(clean)
    row = {"shape": shape, "split": "held-out" if shape in HELD_OUT else "tuning", "changed": {}}
    for name, method in BASELINES.items():
        row["changed"][name] = np.count_nonzero(method(clean) ^ clean) / total
    for name, overrides in VARIANTS.items():
        row["changed"][name] = np.count_nonzero(pipeline.denoise_volume(clean, **overrides).mask ^ clean) / total
    return row


def clean_table(rows):
    methods = list(rows[0]["changed"])
    lines = ["### clean masks: share of the voxels changed\n", "| shape | " + " | ".join(methods) + " |",
             "|---|" + "---|" * len(methods)]
    for r in rows:
        lines.append(f"| {r['shape']} ({r['split']}) | " + " | ".join(f"{r['changed'][m]:.2%}" for m in methods) + " |")
    return "\n".join(lines) + "\n"


def table(rows, split):
    methods = list(rows[0]["methods"])
    own = [r for r in rows if r["split"] == split]
    lines = [f"### {split}: voxel error / input's · thin parts kept · components (clean)\n",
             "| case | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
    for r in own:
        cells = []
        for m in methods:
            e = r["methods"][m]
            cells.append("failed" if "error" in e else
                         f"{e['error_ratio']:.2f} · {e['thin_kept']:.0%} · {e['components']}")
        lines.append(f"| {r['shape']} {r['strength']} ({r['clean_components']}) | " + " | ".join(cells) + " |")
    medians = []
    for m in methods:
        good = [r["methods"][m] for r in own if "error" not in r["methods"][m]]
        medians.append(f"{np.median([e['error_ratio'] for e in good]):.2f} · "
                       f"{np.median([e['thin_kept'] for e in good]):.0%}" if good else "–")
    lines.append("| **median** | " + " | ".join(medians) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--resolution", type=int, default=128)
    p.add_argument("--shapes", default=",".join(SHAPES))
    p.add_argument("--strengths", default=",".join(STRENGTHS), help=f"of {', '.join(STRENGTHS)}")
    p.add_argument("--out", default=os.path.join(shapes.ROOT, "volume-output"))
    p.add_argument("--pictures", action="store_true", help="also draw thin-featured cases (pictures.png)")
    args = p.parse_args(argv)
    rows = []
    for shape in args.shapes.split(","):
        for strength in args.strengths.split(","):
            rows.append(run_case(shape, strength, args.resolution))
            m = rows[-1]["methods"]
            print(f"{shape} {strength}: " + ", ".join(f"{k} {v.get('error_ratio', float('nan')):.2f}"
                                                    for k, v in m.items()), flush=True)
    cleans = [clean_pass(shape, args.resolution) for shape in args.shapes.split(",")]
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({"arguments": sys.argv[1:] if argv is None else argv, "strengths": STRENGTHS, "cases": rows,
                   "clean": cleans}, f, indent=1)
    splits = [split for split in ("tuning", "held-out") if any(r["split"] == split for r in rows)]
    text = "".join(table(rows, split) + "\n" for split in splits)
    text += clean_table(cleans)
    if args.pictures:
        pictures(args.resolution, os.path.join(args.out, "pictures.png"))
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write(text)
    print(text)
    return rows


if __name__ == "__main__":
    main()
