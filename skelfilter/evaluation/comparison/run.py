"""``skelfilter compare``: every method on the same noisy meshes, measured, pictured and reported.

For each case: the clean model, its noisy version (the thesis' noise on the model's voxelization,
§7.2, as a marching-cubes mesh decimated to at most ``max_faces`` faces; or a given noisy/clean pair),
each method's result, :func:`skelfilter.evaluation.metrics.mesh_metrics` against the clean mesh in voxels of the
noise grid, and pictures with one camera per case. Then a threshold sweep of skelfilter on one case
(like the thesis' fig. 4.4), and the report.
"""

import csv
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import trimesh

from skelfilter.core import pipeline
from skelfilter.evaluation import camera, metrics
from skelfilter.evaluation.comparison import render, report
from skelfilter.evaluation.comparison.config import as_dict, slug
from skelfilter.evaluation.comparison.methods import run_method
from skelfilter.evaluation.comparison.output_folder import check_out_folder, move_in, remove_made
from skelfilter.io import mesh_files
from skelfilter.io.samples import sample_path
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.mesh import voxelize
from skelfilter.mesh.closest_points import MeshSurface
from skelfilter.params import DenoiseParams
from skelfilter.runtime.extras import need
from skelfilter.runtime.progress import Progress
from skelfilter.runtime.signals import deferred

COLOUR_RANGE = (0.0, 3.0)  # voxels, the colour maps' scale
SUBPROCESS_KINDS = ("meshlab", "meshlib")  # run in child processes: these may share the CPU


class Reporter:
    """One line per finished piece of work on ``stream`` (stderr), with the time since the start."""

    def __init__(self, enabled=True, stream=None):
        self.enabled = enabled
        self.stream = stream or sys.stderr
        self.start = time.perf_counter()

    def __call__(self, message):
        if self.enabled:
            self.stream.write(f"[{time.perf_counter() - self.start:6.1f} s] {message}\n")
            self.stream.flush()


def _clean_model(model):
    if model == "cube":
        return trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    return mesh_files.load_mesh(sample_path() if model == "fandisk" else model)


def decimate(mesh, max_faces):
    """Quadric edge collapse (open3d) to at most ``max_faces`` faces, unreferenced vertices dropped."""
    if max_faces == 0 or len(mesh.faces) <= max_faces:
        return mesh
    o3d = need("open3d", "the comparison's decimation")
    o3 = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(mesh.vertices),
                                   o3d.utility.Vector3iVector(mesh.faces))
    o3 = o3.simplify_quadric_decimation(int(max_faces))
    out = trimesh.Trimesh(np.asarray(o3.vertices), np.asarray(o3.triangles), process=False)
    out.remove_unreferenced_vertices()
    return out


def prepare_case(case, config):
    """(clean or None, noisy, grid, noise masks or None, facts about the noisy mesh) of one case."""
    if case.synthetic:
        clean = _clean_model(case.model)
        marching, noise, grid = mesh_pipeline.noisy_mesh(clean, case.noise)
        noisy = decimate(marching, config.max_faces)
        chamfer, h95, hmax = metrics.surface_distances(noisy, marching, grid, n_samples=50_000)
        facts = {"marching_cubes_faces": len(marching.faces), "faces": len(noisy.faces),
                 "decimation_chamfer": chamfer, "decimation_hausdorff_95": h95,
                 "decimation_hausdorff_max": hmax, "bump_voxels": int(noise.bumps.sum()),
                 "dent_voxels": int(noise.dents.sum())}
    else:
        noisy = mesh_files.load_mesh(case.noisy)
        clean = None if case.clean is None else mesh_files.load_mesh(case.clean)
        noise = None
        grid = voxelize.grid_for_bounds((noisy if clean is None else clean).bounds, config.resolution, 4)
        facts = {"faces": len(noisy.faces)}
    facts["pitch"] = grid.pitch
    return clean, noisy, grid, noise, facts


def _cameras(case, reference, outcomes):
    """The overview and the close-up camera of a case, and what the close-up shows.

    A configured view looks at the clean model's sharp edge nearest to the eye; a chosen one
    (`camera.view_for`) at the spot where the filters' results lie farthest apart."""
    up = case.up or camera.up_for(case.noisy or case.model or "")
    overview = camera.camera_for(reference, case.view or camera.view_for(reference, up), up)
    results = [o.mesh for o in outcomes.values() if o.error is None and o.filtered]
    if case.view is not None or len(results) < 2:
        return (overview, camera.closeup_camera(reference, overview)), "a sharp edge"
    points, faces = trimesh.sample.sample_surface(reference, 20_000, seed=0)
    spread = np.std([MeshSurface(mesh).distance(points) for mesh in results], axis=0)
    closeup = camera.closeup_where_differ(points, reference.face_normals[faces], spread, overview)
    return (overview, closeup), "where the filters' results differ most"


def _pictures(case_dir, name, mesh, reference, grid, cameras, size):
    """view, close-up and colour map (distance to ``reference``) of one result; paths relative to the
    output folder."""
    out = {}
    for kind, view, scalars in (("view", cameras[0], None), ("closeup", cameras[1], None),
                                ("colormap", cameras[0], metrics.vertex_distances(mesh, reference, grid))):
        path = os.path.join(case_dir, f"{slug(name)}-{kind}.png")
        render.render(mesh, view, path, size, scalars=scalars, clim=COLOUR_RANGE)
        out[kind] = path
    return out


def run_case(case, config, out_dir, say, pool):
    """All methods on one case; returns the case's entry of results.json and its noise masks (or None).

    Measured against the clean mesh where there is one (`metrics.mesh_metrics`), else against the
    input (`metrics.change_measures`); the colour maps show the distance to the same mesh."""
    # The steps that run numba's kernels here hold an interrupt until they end (see `methods.run_method`).
    with deferred():
        clean, noisy, grid, noise, facts = prepare_case(case, config)
    case_dir = os.path.join(out_dir, slug(case.name))
    os.makedirs(case_dir, exist_ok=True)
    mesh_files.save_mesh(noisy, os.path.join(case_dir, "input-noisy.ply"))
    say(f"{case.name}: noisy mesh ready ({facts['faces']} faces)")
    with deferred():  # the pool's threads start with the signals held: they reach the main thread only
        futures = {m.name: pool.submit(run_method, m, noisy, clean, config)
                   for m in config.methods if m.kind in SUBPROCESS_KINDS}
    outcomes = {}
    for method in config.methods:  # in-process methods (numba) run here, meanwhile the children run
        outcome = futures[method.name].result() if method.name in futures else \
            run_method(method, noisy, clean, config)
        say(f"{case.name}: {method.name} " + (f"{outcome.seconds:.1f} s" if outcome.error is None
                                              else f"FAILED: {outcome.error}"))
        outcomes[method.name] = outcome
    reference = noisy if clean is None else clean
    with deferred():
        cameras, closeup = _cameras(case, reference, outcomes)
        noisy_surface = MeshSurface(noisy) if clean is None else None
    entries = []
    for method in config.methods:
        outcome = outcomes[method.name]
        entry = {"name": method.name, "kind": method.kind, "seconds": outcome.seconds, "error": outcome.error}
        if outcome.route is not None:
            entry["route"] = outcome.route
        if outcome.error is None:
            with deferred():
                entry["metrics"] = (metrics.change_measures(outcome.mesh, noisy, grid, source_surface=noisy_surface)
                                    if clean is None
                                    else metrics.mesh_metrics(outcome.mesh, clean, grid, noise))
            entry["error"] = entry["metrics"].get("error")
        if entry["error"] is None:
            entry["mesh"] = os.path.join(case_dir, f"{slug(method.name)}.ply")
            mesh_files.save_mesh(outcome.mesh, entry["mesh"])
            with deferred():
                entry["images"] = _pictures(case_dir, method.name, outcome.mesh, reference, grid, cameras,
                                            config.image_size)
        entries.append(entry)
    say(f"{case.name}: measured and pictured")
    return {"name": case.name, "synthetic": case.synthetic, "reference": "input" if clean is None else "clean",
            "closeup": closeup, "noise": vars(case.noise) if case.synthetic else None, "facts": facts,
            "methods": entries}, noise


def threshold_sweep(name, noise, config, method, say):
    """skelfilter's errors against the threshold t on one case's noise grid (cf. the thesis' fig. 4.4):
    reconstruction error eq. 6.5 (as 1 - |R ∩ X| / |R ∪ X|), bumps removed, dents filled, clean
    volume lost. ``noise``: the case's masks (:class:`skelfilter.core.synthetic_noise.NoiseResult`)."""
    base = config.denoise_params(method) if method is not None else DenoiseParams(resolution=config.resolution)
    rows = []
    for t in config.sweep_thresholds:
        start = time.perf_counter()
        params = base.with_(threshold=t, threshold_relative=None, prune="as-told",
                            geodesic_cap=None if base.geodesic_cap is None else max(base.geodesic_cap, 2 * t))
        mask = pipeline.denoise_volume(noise.noisy, params, Progress(enabled=False, shield=True)).mask
        dents = noise.dents
        rows.append({
            "t": t,
            "reconstruction_error": metrics.reconstruction_error(mask, noise.clean),
            "bumps_removed": 1.0 - (mask & noise.bumps).sum() / max(1, noise.bumps.sum()),
            "dents_filled": float((mask & dents).sum() / dents.sum()) if dents.any() else float("nan"),
            "clean_lost": float((noise.clean & ~mask).sum() / noise.clean.sum()),
            "seconds": time.perf_counter() - start,
        })
        say(f"sweep {name}: t = {t:g}: error {rows[-1]['reconstruction_error']:.4f}, "
            f"{100 * rows[-1]['bumps_removed']:.1f}% of bumps removed")
    return {"case": name, "rows": rows}


def versions():
    """Versions of everything that shaped the numbers."""
    import importlib.metadata as md

    out = {"python": platform.python_version(), "platform": platform.platform(), "cpus": os.cpu_count()}
    for pkg in ("skelfilter", "numpy", "scipy", "scikit-image", "trimesh", "numba", "pymeshlab", "open3d",
                "meshlib", "pyvista", "vtk"):
        try:
            out[pkg] = md.version(pkg)
        except md.PackageNotFoundError:
            out[pkg] = "not installed"
    try:
        here = os.path.dirname(os.path.abspath(__file__))
        out["git commit"] = subprocess.run(["git", "-C", here, "rev-parse", "--short", "HEAD"],
                                           capture_output=True, text=True, timeout=10).stdout.strip() or "-"
    except (OSError, subprocess.SubprocessError):
        out["git commit"] = "-"
    return out


METRIC_COLUMNS = ("noise_removed", "bumps_removed", "dents_removed", "chamfer", "hausdorff_95", "hausdorff_max",
                  "normal_error_deg", "theta_deg", "iou", "shrinkage", "sharp_edge_mean", "sharp_edge_max",
                  "watertight", "edge_manifold", "faces")


def _write_tables(results, out_dir):
    with open(os.path.join(out_dir, "results.json"), "w") as f:
        json.dump(results, f, indent=1, default=float)
    with open(os.path.join(out_dir, "metrics.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(("case", "method", "kind", "seconds", "error") + METRIC_COLUMNS)
        for case in results["cases"]:
            for m in case["methods"]:
                values = m.get("metrics", {})
                w.writerow((case["name"], m["name"], m["kind"], f"{m['seconds']:.3f}", m["error"] or "")
                           + tuple(values.get(c, "") for c in METRIC_COLUMNS))


def _relative(results, out_dir):
    """Paths in results.json and the report relative to the output folder."""
    for case in results["cases"]:
        for m in case["methods"]:
            if "mesh" in m:
                m["mesh"] = os.path.relpath(m["mesh"], out_dir)
            for k, v in m.get("images", {}).items():
                m["images"][k] = os.path.relpath(v, out_dir)


def run_compare(config, out_dir, say=None):
    """Run the whole comparison of ``config`` into ``out_dir``; returns the results dict.

    Writes ``results.json``, ``metrics.csv``, every result mesh (PLY), the pictures, ``report.html``
    and ``report.md``. They are made in a hidden folder inside ``out_dir`` and moved out of it at
    the end, replacing only what an earlier run made (`output_folder.check_out_folder`, before
    anything runs), so a failed or interrupted run leaves nothing behind (and ``out_dir`` itself
    goes if the run made it).
    """
    say = say or Reporter(enabled=False)
    check_out_folder(config, out_dir)
    created = not os.path.isdir(out_dir)
    os.makedirs(out_dir, exist_ok=True)
    work = None
    try:
        with deferred():
            work = tempfile.mkdtemp(dir=out_dir, prefix=".skelfilter-work-")
        results = _run_compare(config, work, say)
        move_in(work, out_dir)
    except BaseException:
        remove_made(out_dir, created, work)
        raise
    shutil.rmtree(work, ignore_errors=True)
    say(f"wrote {os.path.join(out_dir, 'report.html')} and report.md ({results['wall_seconds']:.0f} s)")
    return results


def _duration(seconds):
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.0f} min"


def _run_compare(config, out_dir, say):
    start = time.perf_counter()
    results = {"config": as_dict(config), "versions": versions(), "cases": []}
    sweep_noise = None
    cases = len(config.cases)
    say(f"{cases} models x {len(config.methods)} methods"
        + (f", then a threshold sweep on {config.sweep_case}" if config.sweep_case else "")
        + "; the time left is told after each model")
    with ThreadPoolExecutor(max_workers=config.jobs) as pool:
        for i, case in enumerate(config.cases):
            say(f"case {i + 1}/{cases}: {case.name}")
            entry, noise = run_case(case, config, out_dir, say, pool)
            results["cases"].append(entry)
            if i + 1 < cases:
                left = (time.perf_counter() - start) / (i + 1) * (cases - i - 1)
                say(f"{i + 1} of {cases} models done, about {_duration(left)} left for the others")
            if case.name == config.sweep_case:
                sweep_noise = noise
    if sweep_noise is not None:
        method = next((m for m in config.methods if m.kind == "skelfilter"), None)
        results["sweep"] = threshold_sweep(config.sweep_case, sweep_noise, config, method, say)
    results["wall_seconds"] = time.perf_counter() - start
    _relative(results, out_dir)
    _write_tables(results, out_dir)
    report.write_report(results, out_dir, COLOUR_RANGE)
    return results
