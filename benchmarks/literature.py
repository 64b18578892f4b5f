"""Everyday noise: skelfilter against MeshLab's Taubin and Two-step, pygel3d, MeshLib and the published
state of the art, on the literature's pairs and on Gaussian noise of our own.

Four parts, each a table of the field's two scores (`skelfilter.evaluation.metrics.literature_errors`:
θ, the literature's mean face-normal angle in degrees, and E_v in mean edge lengths), this project's
area-weighted angle beside them, and skelfilter's time:

- ``own``: Gaussian noise along the vertex normals (0.2, 0.3, 0.5, 0.7 mean edge lengths, seed 11)
  on fandisk, the rocker arm and the bunny (the tuning shapes the fine pass was chosen on) and on
  spot and twelve (held out).
- ``literature``: the four pairs of ``benchmarks/data/literature`` (never used to choose anything).
- ``cad``: CAD shapes remeshed the way the literature's CAD meshes are (isotropic, 1/60 of the longest
  side, creases kept; and an irregular copy, half the faces by quadric edge collapse), with Gaussian
  noise along the normals (0.3, 0.5, 0.7 mean edge lengths) and in random directions (0.3, as
  MeshTGV's block): the seven of ``FINE_PASS_CAD`` in ``benchmarks/shapes.py`` and the gear (tuning: the fine
  pass's guided rounds were chosen on them) and the quality benchmark's other CAD parts (held out), against pygel3d and
  skelfilter's bilateral fine pass (``normal_filter="bilateral"``, the fine pass before guided filtering).
- ``sota``: the two pairs of ``benchmarks/data/sota``, with the result their method's authors
  published (GCN-Denoiser, MeshTGV); never used to choose anything.

Rivals, each with the settings it ships with: MeshLab's Taubin and Two-step (their defaults,
``skelfilter/evaluation/comparison/scripts/taubin.mlx`` and ``benchmarks/data/two_step_defaults.mlx``; the
thesis' Two-step, 40 steps for voxel meshes, flattens these meshes to 40°), pygel3d's
``hmesh.anisotropic_smooth`` (10 iterations), MeshLib's
``meshDenoiseViaNormals`` (its defaults).

    python -m benchmarks.literature [--part own|literature|sota|cad|all] [--out FILE.md] [--pictures DIR]

``--pictures`` also draws two pairs (noisy, Taubin, pygel3d, skelfilter, clean; overview and close-up),
the docs' ``docs/everyday-*.png``.
"""

import argparse
import os
import sys
import tempfile
import time

import numpy as np
import trimesh

from benchmarks import shapes
from skelfilter.errors import SkelfilterError
from skelfilter.evaluation import camera, metrics
from skelfilter.evaluation.comparison.methods import meshlib_denoise, pygel3d_smooth
from skelfilter.io import mesh_files as io
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.meshlab import scripts as meshlab
from skelfilter.runtime.progress import Progress

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

SHAPES = os.path.join(ROOT, "skelfilter", "data")  # the clean shapes (package data)
PAIRS_DATA = os.path.join(ROOT, "benchmarks", "data", "literature")  # see benchmarks/data/README.md
PAIRS = ("Fandisk0.3", "Fandisk0.7", "Nicolo0.2", "Bunny0.2")
SOTA_DATA = os.path.join(ROOT, "benchmarks", "data", "sota")
SOTA = {"gcn-trimstar-n3": "GCN-Denoiser", "tgv-block": "MeshTGV"}
OWN_SHAPES = {"fandisk": "fandisk.obj", "rocker-arm": "rocker-arm.obj", "bunny": "stanford-bunny.obj",
              "spot": "spot.obj", "twelve": os.path.join("twelve-impulsive", "clean.obj")}
HELD_OUT = ("spot", "twelve")
LEVELS = (0.2, 0.3, 0.5, 0.7)
SEED = 11
BASELINES = os.path.join(ROOT, "skelfilter", "evaluation", "comparison", "scripts")
TAUBIN = os.path.join(BASELINES, "taubin.mlx")
TWO_STEP = os.path.join(ROOT, "benchmarks", "data", "two_step_defaults.mlx")  # MeshLab's defaults
RIVALS = ("taubin", "two-step", "pygel3d", "meshlib")
# The gear was held out until it showed the guided rounds sharpening its thin teeth, which chose
# fine_pass.ROUND_DISTANCE: it counts as tuning since.
CAD_TUNING = tuple(shapes.FINE_PASS_CAD) + ("gear",)
CAD_HELD_OUT = ("block", "pocket-plate", "u-channel", "l-bracket")
CAD_NOISE = (("normals", 0.3), ("normals", 0.5), ("normals", 0.7), ("random directions", 0.3))
CAD_EDGE = 1.0 / 60.0  # of the longest side


def gaussian_noise(clean, level, seed=SEED):
    """``clean`` with Gaussian noise of ``level`` mean edge lengths along its vertex normals, as the
    literature's pairs were made."""
    rng = np.random.default_rng(seed)
    edge = clean.edges_unique_length.mean()
    offset = rng.normal(0.0, level * edge, len(clean.vertices))
    return trimesh.Trimesh(clean.vertices + clean.vertex_normals * offset[:, None], clean.faces, process=False)


def random_direction_noise(clean, level, seed=SEED):
    """``clean`` with each vertex moved in a random direction by a Gaussian length of ``level`` mean
    edge lengths."""
    rng = np.random.default_rng(seed)
    direction = rng.normal(size=(len(clean.vertices), 3))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    length = rng.normal(0.0, level * clean.edges_unique_length.mean(), (len(clean.vertices), 1))
    return trimesh.Trimesh(clean.vertices + direction * length, clean.faces, process=False)


def remeshed(mesh, irregular=False):
    """``mesh`` remeshed by MeshLab's isotropic explicit remeshing to edges of `CAD_EDGE` (its
    creases of 30 degrees or more kept); ``irregular``: then half its faces taken away by quadric
    edge collapse, which leaves large triangles on flat faces and small ones at creases."""
    import pymeshlab

    meshes = pymeshlab.MeshSet()
    meshes.add_mesh(pymeshlab.Mesh(mesh.vertices, mesh.faces))
    meshes.meshing_isotropic_explicit_remeshing(targetlen=pymeshlab.PureValue(CAD_EDGE), iterations=8, featuredeg=30)
    if irregular:
        meshes.meshing_decimation_quadric_edge_collapse(targetfacenum=meshes.current_mesh().face_number() // 2,
                                                        preserveboundary=True, preservenormal=True,
                                                        planarquadric=True, qualitythr=0.1)
    out = meshes.current_mesh()
    return trimesh.Trimesh(out.vertex_matrix(), out.face_matrix(), process=False)


def cad_row(name, noisy, clean):
    """The scores of noisy, pygel3d, skelfilter's bilateral fine pass and skelfilter on one CAD case."""
    start = time.perf_counter()
    out = mesh_pipeline.denoise_mesh(noisy, progress=Progress(enabled=False))
    seconds = time.perf_counter() - start
    bilateral = mesh_pipeline.denoise_mesh(noisy, progress=Progress(enabled=False), normal_filter="bilateral")
    return {"case": name, "seconds": seconds, "noisy": metrics.literature_errors(noisy, clean),
            "pygel3d": metrics.literature_errors(pygel3d_smooth(noisy), clean),
            "bilateral": metrics.literature_errors(bilateral, clean),
            "skelfilter": metrics.literature_errors(out, clean)}


def cad_table(rows, title):
    """A Markdown table of `cad_row` rows, with skelfilter's angle over the bilateral fine pass's."""
    lines = [f"### {title}", "", "θ (the literature's) / E_v:", "",
             "| case | noisy | pygel3d | skelfilter, bilateral fine pass | skelfilter | θ: skelfilter / bilateral "
             "| time (s) |",
             "|---" * 7 + "|"]
    for r in rows:
        ratio = r["skelfilter"].theta / r["bilateral"].theta
        lines.append(f"| {r['case']} | {_cell(r['noisy'])} | {_cell(r['pygel3d'])} | {_cell(r['bilateral'])} | "
                     f"**{_cell(r['skelfilter'])}** | {ratio:.2f} | {r['seconds']:.1f} |")
    heavy = [r["skelfilter"].theta / r["bilateral"].theta for r in rows
             if "normals 0.5" in r["case"] or "normals 0.7" in r["case"]]
    beat = sum(r["skelfilter"].theta < r["pygel3d"].theta and r["skelfilter"].e_v < r["pygel3d"].e_v for r in rows)
    lines += ["", "- median θ over the bilateral fine pass's, noise of 0.5-0.7 along the normals: "
              f"{np.median(heavy):.2f}",
              f"- below pygel3d on both scores: {beat}/{len(rows)}", ""]
    return "\n".join(lines)


# Pictures for the README: pair -> (view direction, centre -> eye; up).
PICTURES = {"Fandisk0.7": ((1.0, -1.2, 0.9), (0.0, 0.0, 1.0)),
            "tgv-block (MeshTGV)": ((1.0, -1.1, 0.9), (0.0, 0.0, 1.0)),
            "gcn-trimstar-n3 (GCN-Denoiser)": ((0.3, -1.0, 0.8), (0.0, 0.0, 1.0)),
            "Nicolo0.2": ((-0.77, 0.59, -0.24), (0.0, 0.0, 1.0))}
CELL = (380, 340)


def _rival(name, noisy):
    """A rival's result mesh, or None when it fails (a library's crash is a row entry, not the end)."""
    try:
        if name == "taubin":
            return meshlab.run_filter_script(noisy, TAUBIN)
        if name == "two-step":
            return meshlab.run_filter_script(noisy, TWO_STEP)
        return pygel3d_smooth(noisy) if name == "pygel3d" else meshlib_denoise(noisy)
    except SkelfilterError as exc:
        print(f"  {name} failed: {exc}", file=sys.stderr)
        return None


def score_row(name, noisy, clean, pictures=None, published=None):
    """The scores of noisy, every rival, the published result (when given) and skelfilter on one
    pair; pictures in the folder ``pictures`` for the pairs of `PICTURES`."""
    rivals = {r: _rival(r, noisy) for r in RIVALS}
    progress = Progress(enabled=False)
    start = time.perf_counter()
    out = mesh_pipeline.denoise_mesh(noisy, progress=progress)
    seconds = time.perf_counter() - start
    row = {"case": name, "seconds": seconds, "notes": "; ".join(progress.notes),
           "noisy": metrics.literature_errors(noisy, clean), "skelfilter": metrics.literature_errors(out, clean),
           "published": None if published is None else metrics.literature_errors(published, clean)}
    row.update({r: None if m is None else metrics.literature_errors(m, clean) for r, m in rivals.items()})
    if pictures and name in PICTURES:
        second = ("published", published) if published is not None else ("taubin", rivals["taubin"])
        columns = [("noisy", noisy), second, ("pygel3d", rivals["pygel3d"]), ("skelfilter", out), ("clean", clean)]
        pictures_of(name, columns, row, os.path.join(pictures, f"everyday-{name.split()[0]}.png"))
    return row


def pictures_of(name, columns, row, path):
    """An overview and a close-up of a sharp edge, one column per ``(key, mesh)`` of ``columns`` (the
    clean mesh last), each cell drawn by `skelfilter.evaluation.comparison.render` with one camera
    per row, titled with its scores."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from skelfilter.evaluation.comparison import render

    view, up = PICTURES[name]
    meshes = [mesh for _, mesh in columns]
    overview = camera.camera_for(meshes[-1], view, up)
    cameras = (overview, camera.closeup_camera(meshes[-1], overview))
    labels = dict(COLUMNS, skelfilter="skelfilter")
    titles = [f"{labels[key]} {_cell(row[key])}" for key, _ in columns[:-1]] + ["clean"]
    fig, axes = plt.subplots(2, len(meshes), figsize=(CELL[0] / 100 * len(meshes), 2 * CELL[1] / 100 + 0.6), dpi=100)
    with tempfile.TemporaryDirectory() as work:
        for r, cell_camera in enumerate(cameras):
            for c, (mesh, title) in enumerate(zip(meshes, titles)):
                ax = axes[r, c]
                ax.set_axis_off()
                if mesh is None:
                    continue
                cell = os.path.join(work, f"{r}-{c}.png")
                render.render(mesh, cell_camera, cell, CELL)
                ax.imshow(plt.imread(cell))
                if r == 0:
                    ax.set_title(title, fontsize=9)
    fig.suptitle(f"{name}: θ / E_v; bottom row: close-up of a sharp edge", fontsize=11)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _cell(value):
    return "–" if value is None else f"{value.theta:.2f}° / {value.e_v:.3f}"


COLUMNS = (("noisy", "noisy"), ("published", "published"), ("taubin", "MeshLab Taubin"),
           ("two-step", "MeshLab Two-step"), ("pygel3d", "pygel3d"), ("meshlib", "MeshLib"))


def table(rows, title):
    """A Markdown table: θ / E_v per method (the published column only where there is one), then
    skelfilter's and the noisy input's area-weighted angle, and skelfilter's time."""
    columns = [(k, label) for k, label in COLUMNS if any(r[k] is not None for r in rows)]
    head = [label for _, label in columns] + ["skelfilter", "θ area-weighted: noisy / skelfilter", "time (s)"]
    lines = [f"### {title}", "", "θ (the literature's) / E_v:", "", "| case | " + " | ".join(head) + " |",
             "|---" * (len(head) + 1) + "|"]
    for r in rows:
        area = f"{r['noisy'].theta_area:.2f}° / {r['skelfilter'].theta_area:.2f}°"
        cells = [_cell(r[k]) for k, _ in columns] + [f"**{_cell(r['skelfilter'])}**", area, f"{r['seconds']:.1f}"]
        lines.append(f"| {r['case']} | " + " | ".join(cells) + " |")
    lines.append("")
    for k, label in columns[1:]:
        beat = sum(r[k] is not None and r["skelfilter"].theta < r[k].theta and r["skelfilter"].e_v < r[k].e_v
                   for r in rows)
        lines.append(f"- below {label} on both scores: {beat}/{len(rows)}")
    lines.append("")
    return "\n".join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--part", choices=("own", "literature", "sota", "cad", "all"), default="all")
    p.add_argument("--out", help="also write the tables to this Markdown file")
    p.add_argument("--pictures", help="folder for the close-ups (e.g. docs)")
    args = p.parse_args(argv)
    out = ["# Everyday noise: θ (degrees) / E_v (mean edge lengths)", ""]
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
    if args.part in ("sota", "all"):
        rows = []
        for pair, method in SOTA.items():
            folder = os.path.join(SOTA_DATA, pair)
            noisy, clean, published = (io.load_mesh(os.path.join(folder, f"{n}.obj"))
                                       for n in ("noisy", "clean", "published"))
            rows.append(score_row(f"{pair} ({method})", noisy, clean, args.pictures, published))
            print(f"{pair}: {_cell(rows[-1]['skelfilter'])} ({rows[-1]['notes']})", file=sys.stderr, flush=True)
        out.append(table(rows, "Published state of the art (held out)"))
    if args.part in ("cad", "all"):
        for split, names in (("tuning", CAD_TUNING), ("held-out", CAD_HELD_OUT)):
            rows = []
            for name in names:
                for irregular in (False, True):
                    clean = remeshed(shapes.load(name), irregular)
                    for direction, level in CAD_NOISE:
                        noise = gaussian_noise if direction == "normals" else random_direction_noise
                        case = f"{name}{' irregular' if irregular else ''}, {direction} {level}"
                        rows.append(cad_row(case, noise(clean, level), clean))
                        print(f"{case}: {_cell(rows[-1]['skelfilter'])}", file=sys.stderr, flush=True)
            out.append(cad_table(rows, f"CAD shapes of our own, {split}"))
    text = "\n".join(out)
    print(text)
    if args.out:
        io.atomic_write(args.out, lambda tmp: open(tmp, "w").write(text))


if __name__ == "__main__":
    main()
