"""The quality benchmark: skelfilter's variants against MeshLab's and MeshLib's denoisers, to choose
the defaults on a tuning split of shapes and report a held-out split apart (not part of the tests).

    python -m benchmarks.quality --rivals-only --jobs 2      # the rivals into the cache (hours)
    python -m benchmarks.quality [--variant LABEL[:key=value,...]] ... [--clean-pass]

Cases are shapes (`shapes.SHAPES`) x noise kinds (`NOISE_KINDS`) x seeds (`SEEDS`): the thesis' noise
(§7.2) on the shape's voxelization at ``--resolution`` voxels (160), as a marching-cubes mesh. The
shapes of `HELD_OUT` form the held-out split. skelfilter's variants (``DenoiseParams(resolution=...,
**overrides)``, default ``default`` and ``thesis:preset=thesis-tuned``) denoise the marching-cubes mesh; the
rivals (`RIVALS`) get it decimated to at most `MAX_FACES` faces as ``skelfilter compare`` does, run in
niced child processes and are cached on disk (``--cache``, keyed by case, rival and a hash of the
noisy mesh; ``--refresh`` recomputes). The noisy meshes and their voxel masks are cached too.

Every result is scored on the case's noise grid (in its voxels, see `score`); ``--oracle`` adds the
per-ball oracle's output (`run_oracle`), the ceiling of a skeleton decision. ``--out`` gets
``results.json`` (every number), ``table.md`` (per split: a table of the cases, a summary per method
and noise kind, the acceptance targets of ``--check``; see ``quality_tables.py``) and ``sheet.png``
(pictures of representative cases).
"""

import argparse
import contextlib
import hashlib
import json
import multiprocessing
import os
import subprocess
import sys
import time
import warnings
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, fields

import numpy as np
import trimesh

from benchmarks import oracle, quality_tables, shapes
from benchmarks.quality_tables import SPLITS
from skelfilter.core import ball_owners
from skelfilter.core.synthetic_noise import NoiseResult
from skelfilter.evaluation import camera, metrics
from skelfilter.evaluation.comparison import render, report
from skelfilter.evaluation.comparison.config import Method, slug
from skelfilter.evaluation.comparison.methods import run_method
from skelfilter.evaluation.comparison.run import Reporter, decimate, versions
from skelfilter.io import mesh_files
from skelfilter.mesh import marching_cubes
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.mesh.voxelize import Grid, grid_for_bounds, voxelize_on_grid
from skelfilter.params import DenoiseParams, NoiseParams

ROOT = shapes.ROOT
NOISE_KINDS = {
    "stripes": {"p": 0.014, "r": 2.1, "h": 3, "l": 6},
    "high": {"p": 0.01, "r": 2.1, "h": 7, "l": 4},
    "bumps-dents": {"p": 0.014, "r": 2.1, "h": 3, "l": 6, "dents": True},
    "isolated": {"p": 0.004, "r": 2.1, "h": 3, "l": 1},
    "sparse": {"p": 0.003, "r": 2.1, "h": 3, "l": 6},
}
SEEDS = (1, 2)
ORACLE = "oracle"  # the method label of `run_oracle`
HELD_OUT = ("spot", "l-bracket", "twelve", "stool", "gear")  # reported apart: never look at them while tuning
QUICK_SHAPES = ("cube", "fandisk", "block", "l-bracket")
DEFAULT_VARIANTS = ("default", "thesis:preset=thesis-tuned")
SCRIPTS = os.path.join(ROOT, "skelfilter", "evaluation", "comparison", "scripts")
RIVALS = {m.name: m for m in (
    Method("laplacian", "meshlab", script=os.path.join(SCRIPTS, "laplacian_surface_preserving.mlx")),
    Method("two-step", "meshlab", script=os.path.join(SCRIPTS, "two_step.mlx")),
    Method("apss", "meshlab", script=os.path.join(SCRIPTS, "mls_apss.mlx")),
    Method("rimls", "meshlab", script=os.path.join(SCRIPTS, "rimls.mlx")),
    Method("taubin", "meshlab", script=os.path.join(SCRIPTS, "taubin.mlx")),
    Method("meshlib", "meshlib"),
)}
# As skelfilter/evaluation/comparison/default.toml: the rivals' input is decimated to this many faces.
MAX_FACES = 60_000
RIVAL_NICENESS = 10
CLEAN_PASS_PADDING = 8  # voxels around a clean shape on the grid of the clean pass
# Bump when the noisy meshes or the scores change meaning: cached ones are then made again.
NOISY_VERSION = 1
SCORE_VERSION = 5
THIN_RADIUS = 4.0  # voxels: the ball whose opening finds the clean shape's thin parts (`metrics.thin_parts`)
# voxels: bumps left are also counted on parts at most this thin, at least this thick (`metrics.thickness_under`)
THIN_PART, THICK_PART = 3, 13
SHEET_DENTS = ("fandisk", "block", "bunny")  # shapes whose bumps-dents case joins the picture sheet
SHEET_CELL = (420, 340)  # pixels of one rendered picture


def split_of(shape):
    """The split of a shape: ``held-out`` for those of `HELD_OUT`, else ``tuning``."""
    return SPLITS[1] if shape in HELD_OUT else SPLITS[0]


@dataclass(frozen=True)
class Case:
    """One benchmark case: a shape, a noise kind and a seed."""

    shape: str
    kind: str
    seed: int

    @property
    def name(self):
        return f"{self.shape} {self.kind} s{self.seed}"

    @property
    def split(self):
        return split_of(self.shape)

    def noise(self, resolution):
        """The case's NoiseParams on a grid of ``resolution`` voxels."""
        return NoiseParams(resolution=resolution, seed=self.seed, **NOISE_KINDS[self.kind])


@dataclass(frozen=True)
class Setup:
    """What every task needs to know; ``timeout`` (s) is read by
    `skelfilter.evaluation.comparison.methods.run_method`."""

    resolution: int
    cache: str
    refresh: bool
    timeout: float

    def noisy_stem(self, case):
        """Path stem of a case's cached noisy mesh, keyed by the clean mesh and the noise."""
        clean = shapes.load(case.shape)
        key = _digest(clean.vertices, clean.faces, repr(case.noise(self.resolution)), MAX_FACES, NOISY_VERSION)
        return os.path.join(self.cache, "noisy", f"{slug(case.name)}-{self.resolution}-{key}")

    def rival_stem(self, case, rival, noisy_hash):
        """Path stem of a rival's cached result on a case's noisy mesh (hash `mesh_hash`)."""
        return os.path.join(self.cache, "rivals", f"{slug(case.name)}-{rival}-{noisy_hash}")


@dataclass
class Prepared:
    """A case's clean mesh, noisy meshes (marching cubes, decimated), noise masks and grid."""

    clean: trimesh.Trimesh
    marching: trimesh.Trimesh
    decimated: trimesh.Trimesh
    noise: NoiseResult
    grid: Grid
    facts: dict
    thin: np.ndarray = None  # the clean voxels an opening by a radius-THIN_RADIUS ball removes
    bump_classes: dict = None  # "thin", "thick", "over_2h" -> the bump voxels standing on such parts
    concave: np.ndarray = None  # the clean shape's concavities deeper than the noise, but the bumps


def _digest(*parts):
    """A short hex digest of arrays and plain values."""
    h = hashlib.sha256()
    for part in parts:
        h.update(np.ascontiguousarray(part).tobytes() if isinstance(part, np.ndarray) else repr(part).encode())
    return h.hexdigest()[:12]


def mesh_hash(mesh):
    """Digest of a mesh's vertex coordinates (float64) and faces (int64)."""
    return _digest(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64))


def _write_json(path, data):
    """Write ``data`` as JSON atomically (NaN kept as NaN)."""
    mesh_files.atomic_write(path, lambda tmp: _dump(tmp, data))


def _dump(path, data):
    with open(path, "w") as f:
        json.dump(data, f, indent=1, default=float)


def _read_json(path):
    with open(path) as f:
        return json.load(f)


def _save_npz(path, **arrays):
    mesh_files.atomic_write(path, lambda tmp: np.savez_compressed(tmp, **arrays), ())


# ------------------------------------------------------------------------------------------ scores


def _share(part, whole):
    return float(part / whole) if whole else float("nan")


def voxel_references(noise, kind):
    """What `voxel_measures` compares a result with, from a case's noise masks: the clean shape's thin
    parts, its bumps by the part under them (``{"thin", "thick", "over_2h"}``), its concavities deeper
    than the kind's noise height but the bumps' voxels."""
    clean, bumps = noise.clean, noise.bumps
    height = NOISE_KINDS[kind]["h"]
    bump_classes = {"thin": bumps & ~metrics.thickness_under(bumps, clean, THIN_PART),
                    "thick": metrics.thickness_under(bumps, clean, THICK_PART - 1),
                    "over_2h": metrics.thickness_under(bumps, clean, 2 * height)}
    return metrics.thin_parts(clean, THIN_RADIUS), bump_classes, metrics.concavities(clean, height) & ~bumps


def voxel_measures(volume, noise, thin, bump_classes=None, concave=None):
    """`score`'s measures of a result's voxels ``volume`` on the noise grid (``thin``, ``bump_classes``
    and ``concave`` from `voxel_references`; the last two optional, their measures left out)."""
    n_bumps, n_dents, n_clean = (np.count_nonzero(m) for m in (noise.bumps, noise.dents, noise.clean))
    left_bumps = np.count_nonzero(noise.bumps & volume)
    left_dents = np.count_nonzero(noise.dents & ~volume)
    measures = {
        "noise_left": _share(left_bumps + left_dents, n_bumps + n_dents),
        "bumps_left": _share(left_bumps, n_bumps),
        "dents_left": _share(left_dents, n_dents),
        "clean_lost": _share(np.count_nonzero(noise.clean & ~noise.dents & ~volume), n_clean),
        "new_material": _share(np.count_nonzero(volume & ~noise.clean & ~noise.bumps), n_clean),
        **{f"bumps_left_{name}": _share(np.count_nonzero(part & volume), np.count_nonzero(part))
           for name, part in (bump_classes or {}).items()},
        "thin_kept": metrics.thin_parts_kept(volume, thin),
        "error_ratio": _share(np.count_nonzero(volume ^ noise.clean), np.count_nonzero(noise.noisy ^ noise.clean)),
    }
    if concave is not None:
        measures["concavity_filled"] = metrics.concavity_filled(volume, concave)
    return measures


def score(mesh, prep):
    """Every measure of one result against the case's clean shape, in voxels of the noise grid.

    From the result's voxelization V on the noise grid: ``bumps_left`` = |bumps ∩ V| / |bumps|,
    ``dents_left`` = |dents \\ V| / |dents| (NaN without dents), ``noise_left`` (both numerators over
    both denominators), ``clean_lost`` = |(clean \\ dents) \\ V| / |clean|, ``new_material`` =
    |V \\ clean \\ bumps| / |clean|. From the surfaces (`skelfilter.evaluation.metrics`): ``chamfer``,
    ``hausdorff_95``, ``normal_error_deg``, ``sharp_edge_mean``/``sharp_edge_max`` (the clean
    shape's sharp edges to the result). ``genus``/``components``/``genus_from`` by
    `skelfilter.evaluation.metrics.genus` (on the noise grid when the result is no closed manifold), and
    ``voxel_genus``, the genus of V (`skelfilter.evaluation.metrics.voxel_genus`): marching-cubes surfaces have
    sub-voxel tunnels that V does not see. ``thin_kept``: the share of the clean shape's thin parts
    (`skelfilter.evaluation.metrics.thin_parts`, radius `THIN_RADIUS`: plates, rods, rims and edge voxels) in V;
    ``error_ratio``: |V xor clean| over the noisy input's |noisy xor clean| (below 1: better than
    doing nothing). ``bumps_left_thin`` / ``_thick`` / ``_over_2h``: bumps left among those standing on
    parts of the clean shape at most `THIN_PART` voxels thick, at least `THICK_PART`, thicker than twice
    the kind's noise height (`skelfilter.evaluation.metrics.thickness_under`; NaN without such bumps);
    ``concavity_filled``: the share of the clean shape's concavities deeper than the noise height
    (`skelfilter.evaluation.metrics.concavities`: inside its convex hull), less the bumps' voxels (the
    noise's tops stand a little higher than h), that V fills.

    Returns
    -------
    dict
        The measures and ``faces``; ``{"error": reason}`` for an empty or degenerate mesh.
    """
    if len(mesh.faces) == 0 or not np.isfinite(mesh.vertices).all() or not mesh.area > 0:
        return {"error": "empty or degenerate result mesh"}
    grid, noise, clean = prep.grid, prep.noise, prep.clean
    volume = voxelize_on_grid(mesh, grid)
    chamfer, h95, _ = metrics.surface_distances(mesh, clean, grid)
    sharp_mean, sharp_max, _ = metrics.sharp_edge_error(mesh, clean, grid)
    topology = metrics.genus(mesh, grid, volume)
    return {
        **voxel_measures(volume, noise, prep.thin, prep.bump_classes, prep.concave),
        "chamfer": chamfer,
        "hausdorff_95": h95,
        "normal_error_deg": metrics.normal_error(mesh, clean),
        "sharp_edge_mean": sharp_mean,
        "sharp_edge_max": sharp_max,
        "genus": topology["genus"],
        "components": topology["components"],
        "genus_from": topology["from"],
        "voxel_genus": metrics.voxel_genus(volume)["genus"],
        "faces": int(len(mesh.faces)),
    }


# ------------------------------------------------------------------------------------------ noisy cases


def prepare(case, setup):
    """Make (or find in the cache) a case's noisy meshes and masks; returns the case's facts.

    Cached as ``<stem>.npz`` (packed clean/bump/dent masks, noise sites, grid), ``<stem>-marching.ply``
    (the noise's marching-cubes mesh), ``<stem>-decimated.ply`` (the rivals' input, `decimate` to
    `MAX_FACES`) and ``<stem>.json``: face counts, noise voxels, the decimated mesh's hash and the
    marching-cubes mesh's `score` (the ``noisy`` reference; its time is the noise's).
    """
    stem = setup.noisy_stem(case)
    if setup.refresh or not os.path.exists(stem + ".json"):
        _make_noisy(case, setup.resolution, stem)
    facts = _read_json(stem + ".json")
    if facts.get("score_version") != SCORE_VERSION:
        prep = load_case(case, setup)
        facts["noisy"] = {"seconds": facts["noisy"]["seconds"], "error": None, **score(prep.marching, prep)}
        facts["score_version"] = SCORE_VERSION
        _write_json(stem + ".json", facts)
    return facts


def _make_noisy(case, resolution, stem):
    """Write a case's noisy cache files (see `prepare`), the json without scores."""
    start = time.perf_counter()
    marching, noise, grid = mesh_pipeline.noisy_mesh(shapes.load(case.shape), case.noise(resolution))
    decimated = decimate(marching, MAX_FACES)
    os.makedirs(os.path.dirname(stem), exist_ok=True)
    _save_npz(stem + ".npz", clean=np.packbits(noise.clean), bumps=np.packbits(noise.bumps),
              dents=np.packbits(noise.dents), sites=noise.sites, origin=grid.origin, pitch=grid.pitch,
              shape=np.array(grid.shape))
    mesh_files.save_mesh(marching, stem + "-marching.ply")
    mesh_files.save_mesh(decimated, stem + "-decimated.ply")
    seconds = time.perf_counter() - start
    decimated = mesh_files.load_mesh(stem + "-decimated.ply")  # hashed as every later run reads it
    _write_json(stem + ".json", {
        "marching_faces": int(len(marching.faces)), "decimated_faces": int(len(decimated.faces)),
        "decimated_hash": mesh_hash(decimated), "bump_voxels": int(noise.bumps.sum()),
        "dent_voxels": int(noise.dents.sum()), "pitch": grid.pitch, "grid": list(grid.shape),
        "noisy": {"seconds": seconds}})


def load_case(case, setup):
    """The cached `Prepared` case (after `prepare`)."""
    stem = setup.noisy_stem(case)
    with np.load(stem + ".npz") as z:
        grid = Grid(z["origin"], float(z["pitch"]), tuple(z["shape"]))
        n = grid.n_voxels
        clean, bumps, dents = (np.unpackbits(z[k], count=n).view(bool).reshape(grid.shape)
                               for k in ("clean", "bumps", "dents"))
        sites = z["sites"]
    noise = NoiseResult(clean=clean, noisy=(clean | bumps) & ~dents, bumps=bumps, dents=dents, sites=sites)
    return Prepared(shapes.load(case.shape), mesh_files.load_mesh(stem + "-marching.ply"),
                    mesh_files.load_mesh(stem + "-decimated.ply"), noise, grid, _read_json(stem + ".json"),
                    *voxel_references(noise, case.kind))


# ------------------------------------------------------------------------------------------ methods


def run_variant(case, label, params, setup, save_path):
    """Denoise a case's marching-cubes mesh with skelfilter at ``params``, timed and scored.

    The result mesh is written to ``save_path`` unless it is None.
    """
    prep = load_case(case, setup)
    start = time.perf_counter()
    try:
        mesh = mesh_pipeline.denoise_mesh(prep.marching, params)
    except Exception as exc:  # the denoiser under development: record the failure, measure the rest
        return {"seconds": time.perf_counter() - start, "error": f"{type(exc).__name__}: {exc}"}
    seconds = time.perf_counter() - start
    route = mesh.metadata.pop("skelfilter", None)  # what ran: recorded, not written into the mesh file
    if save_path is not None:
        mesh_files.save_mesh(mesh, save_path)
    return {"seconds": seconds, "error": None, "route": route, **score(mesh, prep)}


def run_oracle(case, setup, save_path):
    """The per-ball oracle (`oracle.owned_oracle`: each voxel of the noisy shape flips where the
    skeleton ball that owns it is centred beyond the clean shape, on either side; then
    `ball_owners.seam_smoothed`) as a marching-cubes mesh, scored: the ceiling of a per-ball skeleton
    decision, written to ``save_path`` unless None."""
    prep = load_case(case, setup)
    start = time.perf_counter()
    noisy = prep.noise.noisy
    decided = ball_owners.seam_smoothed(noisy, oracle.owned_oracle(noisy, prep.noise.clean))
    mesh = marching_cubes.mask_to_mesh(decided, prep.grid)
    seconds = time.perf_counter() - start
    if save_path is not None:
        mesh_files.save_mesh(mesh, save_path)
    return {"seconds": seconds, "error": None, **score(mesh, prep)}


def cached_rival(case, rival, facts, setup):
    """A rival's scored entry from the cache, or None when it has to run (or be scored) first."""
    if setup.refresh:
        return None
    stem = setup.rival_stem(case, rival, facts["decimated_hash"])
    if not os.path.exists(stem + ".json"):
        return None
    entry = _read_json(stem + ".json")
    return entry if entry.get("score_version") == SCORE_VERSION else None


def run_rival(case, rival, setup):
    """Run a rival on a case's decimated noisy mesh (in its child process) and score it; both cached.

    A cached result mesh that only lacks current scores is scored again without rerunning the rival.
    Failures are cached too (``--refresh`` retries them).
    """
    prep = load_case(case, setup)
    stem = setup.rival_stem(case, rival, prep.facts["decimated_hash"])
    os.makedirs(os.path.dirname(stem), exist_ok=True)
    if not setup.refresh and os.path.exists(stem + ".npz"):
        mesh, seconds = load_rival_mesh(stem)
        error = None
    else:
        outcome = run_method(RIVALS[rival], prep.decimated, prep.clean, setup)
        mesh, seconds, error = outcome.mesh, outcome.seconds, outcome.error
        if error is None:
            _save_npz(stem + ".npz", vertices=np.asarray(mesh.vertices, dtype=np.float64),
                      faces=np.asarray(mesh.faces, dtype=np.int64), seconds=seconds)
    entry = {"seconds": seconds, "error": error, "score_version": SCORE_VERSION}
    if error is None:
        entry.update(score(mesh, prep))
    _write_json(stem + ".json", entry)
    return entry


def load_rival_mesh(stem):
    """The result mesh of a cached rival run and the rival's time (s)."""
    with np.load(stem + ".npz") as z:
        return trimesh.Trimesh(z["vertices"], z["faces"], process=False), float(z["seconds"])


def clean_pass(shape, params, resolution):
    """What denoising the clean shape itself changes: the share of voxels (of the clean voxelization)
    changed, both meshes voxelized on the shape's grid of ``resolution`` voxels, and
    `skelfilter.evaluation.metrics.pass_through` (99 % of the vertices each way within a share of the diagonal,
    the volume change)."""
    clean = shapes.load(shape)
    start = time.perf_counter()
    try:
        out = mesh_pipeline.denoise_mesh(clean, params)
    except Exception as exc:  # as in run_variant
        return {"seconds": time.perf_counter() - start, "error": f"{type(exc).__name__}: {exc}"}
    seconds = time.perf_counter() - start
    grid = grid_for_bounds(clean.bounds, resolution, CLEAN_PASS_PADDING)
    before, after = voxelize_on_grid(clean, grid), voxelize_on_grid(out, grid)
    return {"seconds": seconds, "error": None,
            "changed": _share(np.count_nonzero(before ^ after), np.count_nonzero(before)),
            **metrics.pass_through(out, clean)}


# ------------------------------------------------------------------------------------------ running


def _init_worker(niceness, threads):
    """Process-pool initializer: lower the priority, share the cores between the workers."""
    import numba

    if niceness:
        os.nice(niceness)
    numba.set_num_threads(threads)


def run_tasks(function, tasks, jobs, say, describe, niceness=0):
    """``function(*task)`` for every task, in ``jobs`` child processes (in this one when ``jobs`` is 1).

    The children run at ``niceness`` more than this process, their numba code on an equal share of
    the cores. Each finished task is reported through ``say(describe(task, result))``.

    Returns
    -------
    list
        The results, in the order of ``tasks``.
    """
    results = [None] * len(tasks)
    if jobs <= 1:
        for i, task in enumerate(tasks):
            results[i] = function(*task)
            say(f"{describe(task, results[i])} ({i + 1}/{len(tasks)})")
        return results
    threads = max(1, (os.cpu_count() or 1) // jobs)
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn"), initializer=_init_worker,
                             initargs=(niceness, threads)) as pool:
        futures = {pool.submit(function, *task): i for i, task in enumerate(tasks)}
        for done, future in enumerate(as_completed(futures), 1):
            i = futures[future]
            results[i] = future.result()
            say(f"{describe(tasks[i], results[i])} ({done}/{len(tasks)})")
    return results


def _outcome(entry):
    return f"{entry['seconds']:.1f} s" if entry.get("error") is None else f"FAILED: {entry['error']}"


def _value(text):
    """A --variant value as int, float, bool, None (``none``: e.g. ``resolution=none``, the mesh's
    own choice) or str, the first that fits."""
    for kind in (int, float):
        with contextlib.suppress(ValueError):
            return kind(text)
    return {"true": True, "false": False, "none": None}.get(text.lower(), text)


def parse_variant(text, resolution):
    """``LABEL[:key=value,...]`` -> (label, DenoiseParams(resolution=resolution, **overrides)).

    A ``preset`` key is dropped with a warning while DenoiseParams has no ``preset`` field.

    Raises
    ------
    ValueError
        On a malformed text or overrides DenoiseParams refuses.
    """
    label, _, spec = text.partition(":")
    if not label:
        raise ValueError(f"variant {text!r} has no label")
    overrides = {}
    for item in filter(None, spec.split(",")):
        key, sep, value = item.partition("=")
        if not sep:
            raise ValueError(f"variant {label}: {item!r} is not key=value")
        overrides[key.strip()] = _value(value.strip())
    if "preset" in overrides and "preset" not in {f.name for f in fields(DenoiseParams)}:
        warnings.warn(f"variant {label}: DenoiseParams has no preset field yet; "
                      f"preset={overrides.pop('preset')} dropped", stacklevel=2)
    try:
        return label, DenoiseParams(**{"resolution": resolution, **overrides})
    except TypeError as exc:
        raise ValueError(f"variant {label}: {exc}") from None


def select_cases(args):
    """The cases of the command line's shapes, kinds, seeds and split, in that order."""
    names = args.shapes or (QUICK_SHAPES if args.quick else tuple(shapes.SHAPES))
    seeds = args.seeds or (SEEDS[:1] if args.quick else SEEDS)
    kinds = args.kinds or tuple(NOISE_KINDS)
    cases = [Case(s, k, seed) for s in names for k in kinds for seed in seeds]
    wanted = {"tuning": SPLITS[:1], "heldout": SPLITS[1:], "all": SPLITS}[args.split]
    return [c for c in cases if c.split in wanted]


def _names(valid, what):
    """An argparse type: a comma-separated list of names from ``valid``."""
    def parse(text):
        items = tuple(x.strip() for x in text.split(",") if x.strip())
        unknown = [x for x in items if x not in valid]
        if unknown:
            raise argparse.ArgumentTypeError(f"unknown {what} {', '.join(unknown)}; known: {', '.join(valid)}")
        return items
    return parse


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default=os.path.join(ROOT, "quality-output"), help="output folder")
    p.add_argument("--cache", default=os.path.join(ROOT, "benchmark-cache"), help="cache folder")
    p.add_argument("--resolution", type=int, default=160, help="noise grid (voxels along the longest side)")
    p.add_argument("--variant", action="append", metavar="LABEL[:key=value,...]",
                   help=f"a skelfilter variant (repeatable; default {' and '.join(DEFAULT_VARIANTS)})")
    p.add_argument("--resolution-override", type=int, metavar="N",
                   help="also run the --check variant at denoise resolution N (label LABEL@N)")
    p.add_argument("--check", default="default", metavar="LABEL", help="variant whose acceptance targets to check")
    p.add_argument("--clean-pass", action="store_true", help="also denoise each clean shape with every variant")
    p.add_argument("--rivals", type=_names(tuple(RIVALS) + ("none",), "rival"), default=tuple(RIVALS),
                   help=f"rivals to include ({','.join(RIVALS)}; or none)")
    p.add_argument("--rivals-only", action="store_true", help="only compute the rivals into the cache")
    p.add_argument("--cached-rivals", action="store_true",
                   help="take the rivals from the cache only, once the variants are done; leave out those "
                        "not computed by then")
    p.add_argument("--refresh", action="store_true", help="recompute the cached noisy meshes and rivals")
    p.add_argument("--timeout", type=float, default=900.0, help="seconds before a rival's child is killed")
    p.add_argument("--shapes", type=_names(tuple(shapes.SHAPES), "shape"),
                   help=f"comma-separated shapes (default all: {','.join(shapes.SHAPES)})")
    p.add_argument("--kinds", type=_names(tuple(NOISE_KINDS), "noise kind"),
                   help=f"comma-separated noise kinds (default all: {','.join(NOISE_KINDS)})")
    p.add_argument("--seeds", type=lambda s: tuple(int(x) for x in s.split(",")),
                   help=f"comma-separated noise seeds (default {','.join(map(str, SEEDS))})")
    p.add_argument("--split", choices=("tuning", "heldout", "all"), default="all",
                   help=f"cases of the tuning shapes, of the held-out ones ({','.join(HELD_OUT)}), or all")
    p.add_argument("--jobs", type=int, default=2, help="child processes at once")
    p.add_argument("--oracle", action="store_true",
                   help="add the per-ball oracle's output (the clean shape decides each skeleton ball; a ceiling)")
    p.add_argument("--no-pictures", action="store_true", help="skip sheet.png")
    p.add_argument("--quick", action="store_true", help=f"one seed, shapes {','.join(QUICK_SHAPES)} (smoke run)")
    args = p.parse_args(argv)
    args.rivals = tuple(r for r in args.rivals if r != "none")
    if args.rivals_only and args.cached_rivals:
        p.error("--rivals-only computes the rivals; --cached-rivals only reads them")
    try:
        args.variants = dict(parse_variant(v, args.resolution) for v in args.variant or DEFAULT_VARIANTS)
    except ValueError as exc:
        p.error(str(exc))
    if args.resolution_override:
        if args.check not in args.variants:
            p.error(f"--resolution-override needs the --check variant {args.check!r} among the variants")
        args.variants[f"{args.check}@{args.resolution_override}"] = \
            args.variants[args.check].with_(resolution=args.resolution_override)
    return args


def sheet_cases(cases):
    """The picture sheet's rows: per shape its first stripes case (else its first case) of the first
    seed, then the bumps-dents cases of `SHEET_DENTS`."""
    seed = min(c.seed for c in cases)
    first = [c for c in cases if c.seed == seed]
    rows = []
    for shape in dict.fromkeys(c.shape for c in first):
        own = [c for c in first if c.shape == shape]
        rows.append(next((c for c in own if c.kind == "stripes"), own[0]))
    rows += [c for c in first if c.kind == "bumps-dents" and c.shape in SHEET_DENTS and c not in rows]
    return rows


def write_sheet(results, cases, setup, out_dir, say):
    """Render the picture sheet ``sheet.png``: rows `sheet_cases`, columns noisy, the variants, the two
    rivals of lowest median Chamfer, clean (cells under ``out_dir/sheet/``)."""
    variants = list(results["settings"]["variants"]) + ([ORACLE] if results["settings"].get("oracle") else [])
    columns = ["noisy"] + variants + quality_tables.best_rivals(results, 2) + ["clean"]
    by_name = {c["name"]: c for c in results["cases"]}
    folder = os.path.join(out_dir, "sheet")
    os.makedirs(folder, exist_ok=True)
    rows = []
    for case in sheet_cases(cases):
        prep = load_case(case, setup)
        shape = shapes.SHAPES[case.shape]
        sheet_camera = camera.camera_for(prep.clean, shape.view, shape.up)
        cells = []
        for column in columns:
            entry = by_name[case.name]["methods"].get(column, {})
            if column == "noisy":
                mesh = prep.marching
            elif column == "clean":
                mesh = prep.clean
            elif entry.get("error") is not None or not entry:
                mesh = None
            elif column in variants:
                mesh = mesh_files.load_mesh(_variant_mesh_path(out_dir, case, column))
            else:
                mesh = load_rival_mesh(setup.rival_stem(case, column, prep.facts["decimated_hash"]))[0]
            if mesh is None:
                cells.append({})
                continue
            path = os.path.join(folder, f"{slug(case.name)}-{slug(column)}.png")
            render.render(mesh, sheet_camera, path, SHEET_CELL)
            cells.append({"images": {"sheet": os.path.relpath(path, out_dir)}})
        rows.append({"name": f"{case.shape}, {case.kind} (seed {case.seed})", "methods": cells})
        say(f"sheet: {case.name}")
    grid = {"config": {"methods": [{"name": c} for c in columns]}, "cases": rows}
    os.replace(os.path.join(out_dir, report.grid_picture(grid, out_dir, "sheet")), os.path.join(out_dir, "sheet.png"))


def uncommitted():
    """Files of skelfilter/ that differ from the checkout's commit: the code measured is not the commit's."""
    try:
        done = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--", "skelfilter"],
                              capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return []
    return [line[3:] for line in done.stdout.splitlines()]


def _variant_mesh_path(out_dir, case, label):
    return os.path.join(out_dir, "meshes", f"{slug(case.name)}-{slug(label)}.ply")


def main(argv=None):
    """Run the benchmark of the command line ``argv``; returns the results dict (None with
    ``--rivals-only``)."""
    args = parse_args(argv)
    say = Reporter()
    setup = Setup(args.resolution, os.path.abspath(args.cache), args.refresh, args.timeout)
    cases = select_cases(args)
    if not cases:
        raise SystemExit("quality: no case selected")
    timings, start = {}, time.perf_counter()
    say(f"{len(cases)} cases, variants {', '.join(args.variants)}, rivals {', '.join(args.rivals) or 'none'}")

    facts = run_tasks(prepare, [(c, setup) for c in cases], args.jobs, say, lambda t, r: f"noisy {t[0].name}")
    facts = dict(zip(cases, facts))
    timings["noisy_s"] = time.perf_counter() - start

    mark = time.perf_counter()
    if not args.cached_rivals:
        rivals = {(c, r): cached_rival(c, r, facts[c], setup) for c in cases for r in args.rivals}
        missing = [(c, r, setup) for (c, r), entry in rivals.items() if entry is None]
        say(f"{len(missing)} rival runs to compute, {len(rivals) - len(missing)} cached")
        done = run_tasks(run_rival, missing, args.jobs, say, lambda t, r: f"{t[0].name}: {t[1]} {_outcome(r)}",
                         niceness=RIVAL_NICENESS)
        rivals.update({(c, r): entry for (c, r, _), entry in zip(missing, done)})
    timings["rivals_s"] = time.perf_counter() - mark
    if args.rivals_only:
        failed = sum(1 for e in rivals.values() if e is not None and e.get("error"))
        say(f"rivals done: {len(rivals)} runs, {failed} failed, {timings['rivals_s']:.0f} s; cache {setup.cache}")
        return None

    mark = time.perf_counter()
    os.makedirs(os.path.join(args.out, "meshes"), exist_ok=True)
    pictured = set(sheet_cases(cases)) if not args.no_pictures else set()
    tasks = [(c, label, params, setup, _variant_mesh_path(args.out, c, label) if c in pictured else None)
             for c in cases for label, params in args.variants.items()]
    done = run_tasks(run_variant, tasks, args.jobs, say, lambda t, r: f"{t[0].name}: {t[1]} {_outcome(r)}")
    variants = {(t[0], t[1]): entry for t, entry in zip(tasks, done)}
    timings["variants_s"] = time.perf_counter() - mark
    if args.oracle:
        mark = time.perf_counter()
        tasks = [(c, setup, _variant_mesh_path(args.out, c, ORACLE) if c in pictured else None) for c in cases]
        done = run_tasks(run_oracle, tasks, args.jobs, say, lambda t, r: f"{t[0].name}: oracle {_outcome(r)}")
        variants.update({(t[0], ORACLE): entry for t, entry in zip(tasks, done)})
        timings["oracle_s"] = time.perf_counter() - mark

    names = list(dict.fromkeys(c.shape for c in cases))
    passes = {}
    if args.clean_pass:
        mark = time.perf_counter()
        keys = [(label, s) for label in args.variants for s in names]
        done = run_tasks(clean_pass, [(s, args.variants[label], args.resolution) for label, s in keys], args.jobs,
                         say, lambda t, r: f"clean pass {t[0]} at {t[1].resolution} {_outcome(r)}")
        for (label, s), entry in zip(keys, done):
            passes.setdefault(label, {})[s] = entry
        timings["clean_pass_s"] = time.perf_counter() - mark
    if args.cached_rivals:  # read last: rivals computed meanwhile by another run are in
        rivals = {(c, r): cached_rival(c, r, facts[c], setup) for c in cases for r in args.rivals}

    results = {
        "settings": {"arguments": list(sys.argv[1:] if argv is None else argv),
                     "resolution": args.resolution, "max_faces": MAX_FACES, "noise_kinds": NOISE_KINDS,
                     "held_out": HELD_OUT, "check": args.check,
                     "variants": {label: asdict(p) for label, p in args.variants.items()},
                     "oracle": args.oracle,
                     "rivals": list(args.rivals), "versions": versions(), "uncommitted": uncommitted()},
        "shapes": _shape_facts(names, args.resolution),
        "cases": [{"name": c.name, "shape": c.shape, "kind": c.kind, "seed": c.seed, "split": c.split,
                   "facts": {k: v for k, v in facts[c].items() if k != "noisy"},
                   "methods": {"noisy": facts[c]["noisy"],
                               **{label: variants[c, label] for label in args.variants},
                               **({ORACLE: variants[c, ORACLE]} if args.oracle else {}),
                               **{r: rivals[c, r] for r in args.rivals if rivals[c, r] is not None}}}
                  for c in cases],
        "clean_pass": passes,
    }
    results["summary"] = quality_tables.summary(results)
    results["acceptance"] = quality_tables.acceptance(results, args.check)
    if not args.no_pictures:
        mark = time.perf_counter()
        write_sheet(results, cases, setup, args.out, say)
        timings["pictures_s"] = time.perf_counter() - mark
    timings["total_s"] = time.perf_counter() - start
    results["timings"] = timings
    quality_tables.write_table(results, os.path.join(args.out, "table.md"))
    _write_json(os.path.join(args.out, "results.json"), results)
    say(f"wrote {args.out}/results.json, table.md" + ("" if args.no_pictures else ", sheet.png")
        + f" ({timings['total_s']:.0f} s)")
    return results


def _shape_facts(names, resolution):
    """Per shape: the split, whether it is a CAD part, its known genus, the genus the clean mesh
    measures (`skelfilter.evaluation.metrics.genus`, on its noise grid when no closed manifold) and the genus of
    its voxelization there (a grid of the noise grid's pitch and voxel centres, padded less)."""
    out = {}
    for name in names:
        clean, shape = shapes.load(name), shapes.SHAPES[name]
        grid = grid_for_bounds(clean.bounds, resolution, CLEAN_PASS_PADDING)
        volume = voxelize_on_grid(clean, grid)
        topology = metrics.genus(clean, grid, volume)
        out[name] = {"split": split_of(name), "cad": shape.cad, "known_genus": shape.genus,
                     "genus": topology["genus"], "components": topology["components"],
                     "genus_from": topology["from"], "voxel_genus": metrics.voxel_genus(volume)["genus"],
                     "faces": int(len(clean.faces))}
    return out


if __name__ == "__main__":
    main()
