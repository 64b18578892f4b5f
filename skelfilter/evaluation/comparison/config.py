"""The comparison's configuration: a TOML file of cases (models and noise) and methods, or meshes alone.

See ``default.toml`` (the thesis' protocol, §8.2.1) for every key. Paths in the file are relative to
the file itself. Errors name the file and the offending entry. `config_for_meshes` makes the
configuration of a user's own meshes: skelfilter's default beside MeshLab's filters.
"""

import math
import os
import tomllib
from dataclasses import dataclass, fields
from importlib import resources

from skelfilter.errors import InputError, ParameterError
from skelfilter.params import DenoiseParams, NoiseParams
from skelfilter.runtime.extras import need

BUILTIN_MODELS = ("cube", "fandisk")
METHOD_KINDS = ("noisy", "clean", "skelfilter", "meshlab", "meshlib")
NOISE_KEYS = ("p", "r", "h", "l", "dents")


@dataclass(frozen=True)
class Case:
    """One row of the comparison: a clean model and how its noisy version is made, or a given noisy
    mesh with its clean mesh, or alone."""

    name: str
    model: str | None = None  # builtin name or path of the clean mesh (synthetic noise)
    noise: NoiseParams | None = None
    noisy: str | None = None  # path of a given noisy mesh
    clean: str | None = None  # its clean mesh; None: measured by what needs no reference
    view: tuple | None = None  # camera direction, from the model's centre towards the eye; None: chosen
    up: tuple | None = None  # None: the model's format's convention (`camera.up_for`)

    @property
    def synthetic(self):
        return self.noise is not None


@dataclass(frozen=True)
class Method:
    """One column: a reference (noisy/clean input) or a denoiser with its parameters."""

    name: str
    kind: str
    script: str | None = None  # MeshLab filter script (.mlx), for kind "meshlab"
    params: dict | None = None  # DenoiseParams fields (skelfilter) or meshlib settings


@dataclass(frozen=True)
class Config:
    path: str | None  # None: made by `config_for_meshes`
    resolution: int  # voxels along the longest side: noise grid, metric unit (and skelfilter's grid)
    seed: int
    max_faces: int  # the noisy marching-cubes mesh is decimated to at most this many faces (0: never)
    jobs: int
    timeout: float  # seconds per method run
    image_size: tuple
    cases: tuple
    methods: tuple
    sweep_case: str | None
    sweep_thresholds: tuple
    skelfilter_at_run_resolution: bool = True  # False: skelfilter's methods choose their grid as the CLI does

    def denoise_params(self, method):
        """The DenoiseParams of a skelfilter method (resolution defaults to the run's)."""
        run = {"resolution": self.resolution} if self.skelfilter_at_run_resolution else {}
        return DenoiseParams(**{**run, **(method.params or {})})


def slug(name):
    """A case's folder name, a method's file name: lower case, letters, digits, ``-`` and ``_``."""
    return "".join(c if c.isalnum() or c in "-_" else "-" for c in name.lower()).strip("-") or "x"


def default_config_path():
    """The shipped default configuration (the thesis' protocol)."""
    return str(resources.files("skelfilter.evaluation.comparison") / "default.toml")


def _fail(path, where, message):
    raise ParameterError(f"{path}: {where}: {message}")


def _check_keys(path, where, table, allowed):
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        _fail(path, where, f"unknown key(s) {', '.join(unknown)}; allowed: {', '.join(sorted(allowed))}")


def _file(path, where, value):
    if not isinstance(value, str):
        _fail(path, where, f"expected a file path, got {value!r}")
    full = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(path)), value))
    if not os.path.isfile(full):
        _fail(path, where, f"no such file {full}")
    return full


def _vector(path, where, value):
    if (not isinstance(value, list) or len(value) != 3
            or not all(isinstance(x, (int, float)) for x in value) or not any(value)):
        _fail(path, where, f"expected three numbers, not all zero, got {value!r}")
    return tuple(float(x) for x in value)


def _case(path, i, table, run):
    where = f"case {i + 1} ({table.get('name', '?')})"
    _check_keys(path, where, table, ("name", "model", "noise", "noisy", "clean", "view", "up"))
    if not isinstance(table.get("name"), str) or not table["name"]:
        _fail(path, where, "every case needs a name")
    kwargs = {"name": table["name"]}
    for key in ("view", "up"):
        if key in table:
            kwargs[key] = _vector(path, f"{where}: {key}", table[key])
    if "model" in table:
        if "noisy" in table or "clean" in table:
            _fail(path, where, "give either model (synthetic noise) or noisy and clean (a real pair)")
        model = table["model"]
        kwargs["model"] = model if model in BUILTIN_MODELS else _file(path, f"{where}: model", model)
        noise = table.get("noise", {})
        if not isinstance(noise, dict):
            _fail(path, where, "noise must be a table of p, r, h, l, dents")
        _check_keys(path, f"{where}: noise", noise, NOISE_KEYS)
        try:
            kwargs["noise"] = NoiseParams(resolution=run["resolution"], seed=run["seed"], **noise)
        except (ParameterError, TypeError) as exc:
            _fail(path, f"{where}: noise", str(exc))
    elif "noisy" in table:
        if "noise" in table:
            _fail(path, where, "a given noisy mesh takes no noise settings")
        kwargs["noisy"] = _file(path, f"{where}: noisy", table["noisy"])
        if "clean" in table:
            kwargs["clean"] = _file(path, f"{where}: clean", table["clean"])
    else:
        _fail(path, where, "needs model (builtin cube or fandisk, or a mesh path) or a noisy mesh's path "
              "(with its clean mesh's, if there is one)")
    return Case(**kwargs)


def _method(path, i, table, run):
    where = f"method {i + 1} ({table.get('name', '?')})"
    _check_keys(path, where, table, ("name", "kind", "script", "params"))
    if not isinstance(table.get("name"), str) or not table["name"]:
        _fail(path, where, "every method needs a name")
    kind = table.get("kind")
    if kind not in METHOD_KINDS:
        _fail(path, where, f"kind must be one of {', '.join(METHOD_KINDS)}, got {kind!r}")
    params = table.get("params", {})
    if not isinstance(params, dict):
        _fail(path, where, "params must be a table")
    script = None
    if kind == "meshlab":
        if "script" not in table:
            _fail(path, where, "a meshlab method needs script = path of a .mlx filter script")
        script = _file(path, f"{where}: script", table["script"])
        from skelfilter.meshlab.scripts import read_filter_script

        read_filter_script(script)  # a bad script fails now, not after an hour of running
    elif "script" in table:
        _fail(path, where, "only meshlab methods take a script")
    if kind == "skelfilter":
        try:
            DenoiseParams(**{"resolution": run["resolution"], **params})
        except (ParameterError, TypeError) as exc:
            _fail(path, f"{where}: params", str(exc))
    elif kind == "meshlib":
        _check_keys(path, f"{where}: params", params, _meshlib_settings())
    elif params:
        _fail(path, where, f"a {kind} method takes no params")
    return Method(name=table["name"], kind=kind, script=script, params=dict(params))


def _meshlib_settings():
    try:
        mm = need("meshlib.mrmeshpy", "the comparison")
    except ImportError:
        return ()
    s = mm.DenoiseViaNormalsSettings()
    return tuple(a for a in dir(s) if not a.startswith("_") and not callable(getattr(s, a)))


_RUN_DEFAULTS = {"resolution": 160, "seed": 1, "max_faces": 60_000, "jobs": 2, "timeout": 900.0,
                 "image_size": [420, 340]}


def _run_table(path, table):
    _check_keys(path, "[run]", table, _RUN_DEFAULTS)
    run = {**_RUN_DEFAULTS, **table}
    if not isinstance(run["resolution"], int) or run["resolution"] < 16:
        _fail(path, "[run]", f"resolution must be an integer >= 16, got {run['resolution']!r}")
    if not isinstance(run["seed"], int):
        _fail(path, "[run]", f"seed must be an integer, got {run['seed']!r}")
    if not isinstance(run["max_faces"], int) or not (run["max_faces"] == 0 or run["max_faces"] >= 1000):
        _fail(path, "[run]", f"max_faces must be 0 (keep every face) or an integer >= 1000, got {run['max_faces']!r}")
    if not isinstance(run["jobs"], int) or run["jobs"] < 1:
        _fail(path, "[run]", f"jobs must be a positive integer, got {run['jobs']!r}")
    if not isinstance(run["timeout"], (int, float)) or not math.isfinite(run["timeout"]) or run["timeout"] <= 0:
        _fail(path, "[run]", f"timeout must be a positive number of seconds, got {run['timeout']!r}")
    size = run["image_size"]
    if not (isinstance(size, list) and len(size) == 2 and all(isinstance(x, int) and 64 <= x <= 4096 for x in size)):
        _fail(path, "[run]", f"image_size must be [width, height] in pixels (64-4096), got {size!r}")
    return run


def load_config(path=None, **overrides):
    """Read and check a comparison configuration.

    Parameters
    ----------
    path : str, optional
        TOML file; the shipped default (thesis protocol) when omitted.
    **overrides
        Values of the ``[run]`` table that replace the file's (e.g. ``jobs=1``).

    Returns
    -------
    Config

    Raises
    ------
    InputError
        Missing or unparsable file.
    ParameterError
        Unknown key, bad value, missing file named in it; the message names the entry.
    """
    path = str(path or default_config_path())
    try:
        with open(path, "rb") as f:
            data = tomllib.load(f)
    except FileNotFoundError:
        raise InputError(f"{path}: no such configuration file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not valid TOML ({exc})") from None
    _check_keys(path, "top level", data, ("run", "case", "method", "sweep"))
    for key, kind in (("run", "a table [run]"), ("sweep", "a table [sweep]"), ("case", "a list of [[case]] tables"),
                      ("method", "a list of [[method]] tables")):
        value = data.get(key)
        is_list = isinstance(value, list) and all(isinstance(v, dict) for v in value)
        if value is not None and not (is_list if key in ("case", "method") else isinstance(value, dict)):
            _fail(path, key, f"must be {kind}, got {type(value).__name__} {value!r}")
    run = _run_table(path, {**data.get("run", {}), **{k: v for k, v in overrides.items() if v is not None}})
    cases = tuple(_case(path, i, t, run) for i, t in enumerate(data.get("case", [])))
    methods = tuple(_method(path, i, t, run) for i, t in enumerate(data.get("method", [])))
    if not cases or not methods:
        _fail(path, "top level", "needs at least one [[case]] and one [[method]]")
    _check_unique(path, cases, methods)
    sweep = data.get("sweep", {})
    _check_keys(path, "[sweep]", sweep, ("case", "thresholds"))
    sweep_case = sweep.get("case")
    if sweep_case is not None:
        case = next((c for c in cases if c.name == sweep_case), None)
        if case is None or not case.synthetic:
            _fail(path, "[sweep]", f"case must name a case with synthetic noise, got {sweep_case!r}")
    thresholds = sweep.get("thresholds", [])
    if sweep_case is not None and (not thresholds or not all(
            isinstance(t, (int, float)) and t > 0 for t in thresholds)):
        _fail(path, "[sweep]", "thresholds must be a non-empty list of positive numbers (voxels)")
    return Config(path=path, resolution=run["resolution"], seed=run["seed"], max_faces=run["max_faces"],
                  jobs=run["jobs"], timeout=float(run["timeout"]), image_size=tuple(run["image_size"]),
                  cases=cases, methods=methods, sweep_case=sweep_case,
                  sweep_thresholds=tuple(float(t) for t in thresholds))


def _check_unique(path, cases, methods):
    """Every case its own folder, every method its own file names."""
    for kind, items in (("case", cases), ("method", methods)):
        folders = {"input-noisy": "the noisy input's mesh"} if kind == "method" else {}
        for x in items:
            other = folders.setdefault(slug(x.name), repr(x.name))
            if other != repr(x.name):
                _fail(path, "top level", f"{kind} names {other} and {x.name!r} give one file name "
                      f"{slug(x.name)!r}; rename one")


# MeshLab's filters beside skelfilter on a user's meshes, with the thesis' parameters (§8.2.1).
MESHLAB_SCRIPTS = (("Laplacian", "laplacian_surface_preserving.mlx"), ("Two-step", "two_step.mlx"),
                   ("MLS (APSS)", "mls_apss.mlx"), ("RIMLS", "rimls.mlx"))


def _case_names(paths):
    """A case name per mesh: its file name, numbered where two meshes share one."""
    names, seen = [], {}
    for path in paths:
        name = os.path.basename(path)
        seen[slug(name)] = seen.get(slug(name), 0) + 1
        names.append(name if seen[slug(name)] == 1 else f"{name} ({seen[slug(name)]})")
    return names


def config_for_meshes(paths, clean=None, **overrides):
    """The comparison of a user's own meshes: each as it is, skelfilter's default (its grid chosen as
    the CLI chooses it) beside MeshLab's Laplacian, Two-step, MLS and RIMLS filters.

    Parameters
    ----------
    paths : sequence of str
        Mesh files.
    clean : str, optional
        The clean mesh of the one mesh in ``paths``: the full metrics against it. Without it each
        result is measured by what needs no reference (roughness, how far it moved, volume change).
    **overrides
        Values of the ``[run]`` table (``jobs``, ``resolution``: the metrics' grid, ...).

    Returns
    -------
    Config

    Raises
    ------
    ParameterError
        ``clean`` with more than one mesh, a bad ``[run]`` value.
    InputError
        A path that is not a file.
    """
    paths = [str(p) for p in paths]
    if not paths:
        raise ParameterError("compare: no mesh given")
    if clean is not None and len(paths) != 1:
        raise ParameterError(f"--clean: a clean mesh belongs to one noisy mesh, got {len(paths)} meshes")
    for file in paths + ([str(clean)] if clean is not None else []):
        if not os.path.isfile(file):
            raise InputError(f"{file}: no such file")
    run = _run_table("compare", {k: v for k, v in overrides.items() if v is not None})
    cases = tuple(Case(name=name, noisy=os.path.abspath(p), clean=None if clean is None else os.path.abspath(clean))
                  for name, p in zip(_case_names(paths), paths))
    scripts = resources.files("skelfilter.evaluation.comparison") / "scripts"
    methods = ((Method("input", "noisy"), Method("skelfilter", "skelfilter", params={}))
               + tuple(Method(name, "meshlab", script=str(scripts / file)) for name, file in MESHLAB_SCRIPTS)
               + ((Method("clean", "clean"),) if clean is not None else ()))
    _check_unique("compare", cases, methods)
    return Config(path=None, resolution=run["resolution"], seed=run["seed"], max_faces=run["max_faces"],
                  jobs=run["jobs"], timeout=float(run["timeout"]), image_size=tuple(run["image_size"]),
                  cases=cases, methods=methods, sweep_case=None, sweep_thresholds=(),
                  skelfilter_at_run_resolution=False)


def as_dict(config):
    """Plain-data form of a configuration, for the report and results.json."""
    out = {}
    for f in fields(config):
        value = getattr(config, f.name)
        if f.name in ("cases", "methods"):
            value = [{k: (vars(v) if isinstance(v, NoiseParams) else v) for k, v in vars(x).items()}
                     for x in value]
        out[f.name] = value
    return out
