"""What the default runs on each input of the routing corpus, against what the input needs.

    python -m benchmarks.routing [--out docs/routing.md] [--split tuning|held-aside|all] [--errors]

Each case of ``routing_corpus.CASES`` is denoised with the default preset (no flags) and the route is
read from what happened: ``none`` (the output equals the input), ``fine`` (the input mesh came back
smoothed) or ``skeleton`` (the voxel stage pruned: a new closed mesh). The report holds the
confusion table per split, every case with its roughness and route, and with ``--errors`` the
literature's θ (mean face-normal angle to the truth) and the change measured on clean inputs
(largest vertex move over the bounding box's diagonal).
"""

import argparse
import datetime
import sys
import time
import warnings

import numpy as np
import trimesh

from benchmarks import routing_corpus
from skelfilter.evaluation import metrics
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.mesh import route
from skelfilter.runtime.progress import Progress

ROUTES = routing_corpus.NEEDS


def route_of(mesh, out, result):
    """The route the default took: none, fine or skeleton."""
    if result is not None and result.stages and len(out.faces) != len(mesh.faces):
        return "skeleton"
    if len(out.vertices) == len(mesh.vertices) and np.array_equal(np.asarray(out.vertices), np.asarray(mesh.vertices)):
        return "none"
    return "fine"


def run_case(name, errors):
    case = routing_corpus.CASES[name]
    mesh, clean = routing_corpus.load(name)
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out, result, _ = mesh_pipeline.denoise_mesh_detailed(mesh, progress=Progress(enabled=False))
    seconds = time.perf_counter() - start
    roughness = route.measure(mesh)
    row = {"name": name, "kind": case.kind, "storage": case.storage, "split": case.split, "needs": case.needs,
           "ran": route_of(mesh, out, result), "fine": roughness.fine, "coarse": roughness.coarse,
           "correlation": roughness.correlation,
           "faces": len(mesh.faces), "seconds": seconds}
    if errors:
        diagonal = float(np.linalg.norm(np.ptp(np.asarray(clean.vertices), axis=0)))
        if case.needs == "none":
            same = len(out.vertices) == len(mesh.vertices)
            row["moved"] = (float(np.abs(np.asarray(out.vertices) - np.asarray(mesh.vertices)).max()) / diagonal
                            if same else float("nan"))
        elif len(clean.faces) == len(mesh.faces) or case.needs == "skeleton":
            if case.storage == "stl":  # scored like the indexed file: the same faces, the clean mesh's indices
                mesh, out = (_indexed_like(m, clean) for m in (mesh, out))
            row["theta_in"] = metrics.literature_errors(mesh, clean).theta
            row["theta_out"] = metrics.literature_errors(out, clean).theta
    return row


def _indexed_like(mesh, clean):
    """``mesh`` (an STL's triangles, corners apart, in ``clean``'s face order) on ``clean``'s vertex indices."""
    vertices = np.zeros((len(clean.vertices), 3))
    vertices[np.asarray(clean.faces).reshape(-1)] = np.asarray(mesh.vertices)[np.asarray(mesh.faces).reshape(-1)]
    return trimesh.Trimesh(vertices, np.asarray(clean.faces), process=False)


def confusion(rows):
    table = {(a, b): 0 for a in ROUTES for b in ROUTES}
    for row in rows:
        table[row["needs"], row["ran"]] += 1
    lines = ["| needed \\ ran | " + " | ".join(ROUTES) + " |", "|---|" + "---|" * len(ROUTES)]
    for a in ROUTES:
        lines.append(f"| {a} | " + " | ".join(str(table[a, b]) for b in ROUTES) + " |")
    return "\n".join(lines)


def _fmt(value, digits=2):
    return "–" if value is None or (isinstance(value, float) and np.isnan(value)) else f"{value:.{digits}f}"


def report(rows, errors):
    out = ["# Routing: what the default runs on each input", "",
           f"Made by `python -m benchmarks.routing{' --errors' if errors else ''}` on "
           f"{datetime.date.today().isoformat()}. The corpus and the classes: "
           "`benchmarks/routing_corpus.py`; the measure: `skelfilter/mesh/surface_roughness.py`; the "
           "decision: `skelfilter/mesh/route.py`.", ""]
    for split in ("tuning", "held-aside"):
        part = [r for r in rows if r["split"] == split]
        if not part:
            continue
        right = sum(r["needs"] == r["ran"] for r in part)
        out += [f"## {split}: {right} of {len(part)} routed as needed", "", confusion(part), ""]
    real = [r for r in rows if r["kind"] == "real"]
    if real and errors:
        same = sum(r["ran"] == "none" and r["moved"] <= 0.001 for r in real)
        out += [f"## Real models: {same} of {len(real)} unchanged", "",
                "The models bundled with the installed packages (`routing_corpus.REAL_MODELS`, held aside), "
                "each within 0.1 % of its diagonal of the input; the largest move measured: "
                f"{max(r['moved'] for r in real):.4f} of the diagonal.", ""]
    out += ["## Every case", "",
            "roughness: median residual of the normals (degrees), fine scale / over wider patches; "
            "corr.: how alike neighbouring vertices' offsets are (Moran's I, where the roughness is fine-scale "
            "only); "
            "moved: largest vertex move over the diagonal (clean inputs); θ: the literature's mean face-normal "
            "angle to the truth, in / out (degrees).", "",
            "| case | kind | stored | split | needs | ran | roughness | corr. | faces | s | moved | θ in | θ out |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['name']} | {r['kind']} | {r['storage']} | {r['split']} | {r['needs']} | "
                   f"{'**' + r['ran'] + '**' if r['ran'] != r['needs'] else r['ran']} | "
                   f"{_fmt(r['fine'], 1)} / {_fmt(r['coarse'], 1)} | {_fmt(r['correlation'])} | {r['faces']} | "
                   f"{r['seconds']:.1f} | "
                   f"{_fmt(r.get('moved'), 4)} | {_fmt(r.get('theta_in'), 1)} | {_fmt(r.get('theta_out'), 1)} |")
    return "\n".join(out) + "\n"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=None, help="write the report here (markdown)")
    parser.add_argument("--split", choices=("tuning", "held-aside", "all"), default="all")
    parser.add_argument("--errors", action="store_true", help="also the error against the truth")
    parser.add_argument("--case", action="append", help="only these cases")
    args = parser.parse_args(argv)
    names = args.case or [n for n, c in routing_corpus.CASES.items() if args.split in ("all", c.split)]
    rows = []
    for name in names:
        row = run_case(name, args.errors)
        rows.append(row)
        print(f"{name:32s} needs {row['needs']:8s} ran {row['ran']:8s} roughness {_fmt(row['fine'], 1)}/"
              f"{_fmt(row['coarse'], 1)}/{_fmt(row['correlation'])}  {row['seconds']:.1f} s", flush=True)
    text = report(rows, args.errors)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
