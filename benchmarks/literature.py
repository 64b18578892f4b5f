"""Everyday noise: skelfilter against MeshLab Taubin and pygel3d on the literature's pairs and on
Gaussian noise of our own.

Two parts, each a table of the field's two scores (`skelfilter.evaluation.metrics.literature_errors`: mean
face-normal angle in degrees / E_v in mean edge lengths) and skelfilter's time:

- ``own``: Gaussian noise along the vertex normals (0.2, 0.3, 0.5, 0.7 mean edge lengths, seed 11)
  on fandisk, the rocker arm and the bunny (the tuning shapes the fine pass was chosen on) and on
  spot and twelve (held out).
- ``literature``: the four pairs of ``shared/data/literature`` (never used to choose anything),
  the acceptance of the everyday-scan issue: skelfilter without flags below MeshLab Taubin (its
  defaults, ``skelfilter/evaluation/comparison/scripts/taubin.mlx``) on both scores on every pair, and below pygel3d's
  ``hmesh.anisotropic_smooth`` (10 iterations) on the two fandisk pairs.

    python benchmarks/literature.py [--part own|literature|all] [--out FILE.md] [--pictures DIR]

``--pictures`` also draws two pairs (noisy, Taubin, pygel3d, skelfilter, clean; overview and close-up),
the README's ``docs/everyday-*.png``.
"""

import argparse
import os
import sys
import tempfile
import time

import numpy as np
import trimesh

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from skelfilter.errors import SkelfilterError  # noqa: E402
from skelfilter.evaluation import metrics  # noqa: E402
from skelfilter.evaluation.comparison.methods import pygel3d_smooth  # noqa: E402
from skelfilter.io import mesh_files as io  # noqa: E402
from skelfilter.mesh import pipeline as mesh_pipeline  # noqa: E402
from skelfilter.meshlab import scripts as meshlab  # noqa: E402
from skelfilter.runtime.progress import Progress  # noqa: E402

SHAPES = os.path.join(ROOT, "skelfilter", "data")  # the clean shapes (package data)
PAIRS_DATA = os.path.join(ROOT, "benchmarks", "data", "literature")  # see benchmarks/data/README.md
PAIRS = ("Fandisk0.3", "Fandisk0.7", "Nicolo0.2", "Bunny0.2")
OWN_SHAPES = {"fandisk": "fandisk.obj", "rocker-arm": "rocker-arm.obj", "bunny": "stanford-bunny.obj",
              "spot": "spot.obj", "twelve": os.path.join("twelve-impulsive", "clean.obj")}
HELD_OUT = ("spot", "twelve")
LEVELS = (0.2, 0.3, 0.5, 0.7)
SEED = 11
TAUBIN = os.path.join(ROOT, "skelfilter", "evaluation", "comparison", "scripts", "taubin.mlx")


def gaussian_noise(clean, level, seed=SEED):
    """``clean`` with Gaussian noise of ``level`` mean edge lengths along its vertex normals, as the
    literature's pairs were made."""
    rng = np.random.default_rng(seed)
    edge = clean.edges_unique_length.mean()
    offset = rng.normal(0.0, level * edge, len(clean.vertices))
    return trimesh.Trimesh(clean.vertices + clean.vertex_normals * offset[:, None], clean.faces, process=False)


# Pictures for the README: pair -> (view direction, centre -> eye; up).
PICTURES = {"Fandisk0.7": ((1.0, -1.2, 0.9), (0.0, 0.0, 1.0)),
            "Nicolo0.2": ((-0.77, 0.59, -0.24), (0.0, 0.0, 1.0))}
CELL = (380, 340)


def results(noisy, clean):
    """The result meshes of Taubin, pygel3d (None when it fails) and skelfilter, with skelfilter's
    time and notes."""
    taubin = meshlab.run_filter_script(noisy, TAUBIN)
    try:
        pygel = pygel3d_smooth(noisy)
    except SkelfilterError as exc:  # a library's crash is a row entry, not the end of the run
        pygel = None
        print(f"  pygel3d failed: {exc}", file=sys.stderr)
    progress = Progress(enabled=False)
    start = time.perf_counter()
    out = mesh_pipeline.denoise_mesh(noisy, progress=progress)
    return taubin, pygel, out, time.perf_counter() - start, "; ".join(progress.notes)


def score_row(name, noisy, clean, pictures=None):
    """The scores of noisy, Taubin, pygel3d and skelfilter on one pair; pictures in the folder
    ``pictures`` for the pairs of `PICTURES`."""
    taubin, pygel, out, seconds, notes = results(noisy, clean)
    row = {"case": name, "noisy": metrics.literature_errors(noisy, clean), "seconds": seconds, "notes": notes,
           "taubin": metrics.literature_errors(taubin, clean),
           "pygel3d": None if pygel is None else metrics.literature_errors(pygel, clean),
           "skelfilter": metrics.literature_errors(out, clean)}
    if pictures and name in PICTURES:
        pictures_of(name, [noisy, taubin, pygel, out, clean], row, os.path.join(pictures, f"everyday-{name}.png"))
    return row


def pictures_of(name, meshes, row, path):
    """An overview and a close-up of a sharp edge (noisy, Taubin, pygel3d, skelfilter, clean), each
    cell drawn by `skelfilter.evaluation.comparison.render` with one camera per row, titled with its scores."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from skelfilter.evaluation.comparison import render

    view, up = PICTURES[name]
    overview = render.camera_for(meshes[-1], view, up)
    cameras = (overview, render.closeup_camera(meshes[-1], overview))
    titles = [f"noisy {_cell(row['noisy'])}", f"MeshLab Taubin {_cell(row['taubin'])}",
              f"pygel3d {_cell(row['pygel3d'])}", f"skelfilter {_cell(row['skelfilter'])}", "clean"]
    fig, axes = plt.subplots(2, len(meshes), figsize=(CELL[0] / 100 * len(meshes), 2 * CELL[1] / 100 + 0.6), dpi=100)
    with tempfile.TemporaryDirectory() as work:
        for r, camera in enumerate(cameras):
            for c, (mesh, title) in enumerate(zip(meshes, titles)):
                ax = axes[r, c]
                ax.set_axis_off()
                if mesh is None:
                    continue
                cell = os.path.join(work, f"{r}-{c}.png")
                render.render(mesh, camera, cell, CELL)
                ax.imshow(plt.imread(cell))
                if r == 0:
                    ax.set_title(title, fontsize=9)
    fig.suptitle(f"{name}: mean normal angle / E_v; bottom row: close-up of a sharp edge", fontsize=11)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _cell(value):
    return "–" if value is None else f"{value[0]:.2f}° / {value[1]:.3f}"


def table(rows, title):
    lines = [f"### {title}", "", "| case | noisy | MeshLab Taubin | pygel3d anisotropic | skelfilter | time (s) |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {_cell(r['noisy'])} | {_cell(r['taubin'])} | {_cell(r['pygel3d'])} | "
                     f"**{_cell(r['skelfilter'])}** | {r['seconds']:.1f} |")
    beat = sum(r["skelfilter"][0] < r["taubin"][0] and r["skelfilter"][1] < r["taubin"][1] for r in rows)
    lines += ["", f"Below Taubin on both scores: {beat}/{len(rows)}.", ""]
    return "\n".join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--part", choices=("own", "literature", "all"), default="all")
    p.add_argument("--out", help="also write the tables to this Markdown file")
    p.add_argument("--pictures", help="folder for the close-ups (e.g. docs)")
    args = p.parse_args(argv)
    out = ["# Everyday noise: mean normal angle / E_v (mean edge lengths)", ""]
    if args.part in ("own", "all"):
        for split, names in (("tuning", [s for s in OWN_SHAPES if s not in HELD_OUT]), ("held-out", HELD_OUT)):
            rows = []
            for name in names:
                clean = io.load_mesh(os.path.join(SHAPES, OWN_SHAPES[name]))
                for level in LEVELS:
                    rows.append(score_row(f"{name} {level}", gaussian_noise(clean, level), clean))
                    print(f"{rows[-1]['case']}: {_cell(rows[-1]['skelfilter'])}", file=sys.stderr, flush=True)
            out.append(table(rows, f"Gaussian noise of our own, {split} shapes"))
    if args.part in ("literature", "all"):
        rows = []
        for pair in PAIRS:
            folder = os.path.join(PAIRS_DATA, pair)
            rows.append(score_row(pair, io.load_mesh(os.path.join(folder, "noisy.obj")),
                                  io.load_mesh(os.path.join(folder, "clean.obj")), args.pictures))
            print(f"{pair}: {_cell(rows[-1]['skelfilter'])} ({rows[-1]['notes']})", file=sys.stderr, flush=True)
        out.append(table(rows, "The literature's pairs (held out)"))
    text = "\n".join(out)
    print(text)
    if args.out:
        io.atomic_write(args.out, lambda tmp: open(tmp, "w").write(text))


if __name__ == "__main__":
    main()
