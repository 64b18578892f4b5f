"""MeshLab's filters as pymeshlab runs them: names, parameter lists, and a crash-safe child process.

A MeshLab filter in a script is named as MeshLab shows it ("Taubin Smooth"); pymeshlab calls it
``apply_coord_taubin_smoothing`` and lowercases its parameter names (``stepSmoothNum`` ->
``stepsmoothnum``). :func:`check_filter` maps both and checks every parameter's name and .mlx type
against pymeshlab's own parameter list of the filter (what ``pymeshlab.print_filter_parameter_list``
prints).

:func:`run_filters` applies MeshLab filters to a stack of layers in a separate Python process, so a
crash in MeshLab's C++ code (segmentation fault, abort) or a hang becomes a
:class:`~skelfilter.errors.SkelfilterError` instead of killing the caller. The child gets every layer
and the current one, as a MeshSet holds them, and gives back every layer and the current one: a filter
that creates a layer (``generate_copy_of_current_mesh``, ...) makes it current, as in MeshLab.

The MLS projections (APSS, RIMLS) crash when the mesh is projected onto itself (both layers 0, the
default). They are always applied the way that works: the current layer with freshly computed
per-vertex normals is the point set (layer 0 of a separate MeshSet), a copy of it the projected proxy
(layer 1), ``controlmesh=0, proxymesh=1``; the projection replaces the current layer. The script's
own ControlMesh/ProxyMesh values are ignored. Rebuilding the MeshSet around it drops per-vertex
attributes (normals, colours, quality) of all layers; vertices and faces are what passes between
filters anyway.
"""

import functools
import json
import keyword
import os
import re
import subprocess
import sys

import numpy as np

from skelfilter.errors import InputError, SkelfilterError
from skelfilter.meshlab import mlx
from skelfilter.runtime.child import run_child
from skelfilter.runtime.extras import need
from skelfilter.runtime.signals import temporary_folder

MLS_FILTERS = ("compute_mls_projection_apss", "compute_mls_projection_rimls")

# pymeshlab's type of a parameter (as print_filter_parameter_list names it) -> .mlx types carrying it
_RICH_TYPES_OF = {
    "bool": ("RichBool",),
    "int": ("RichInt", "RichMesh"),
    "float": ("RichFloat", "RichDynamicFloat"),
    "float (bounded)": ("RichDynamicFloat", "RichFloat"),
    "PercentageValue": ("RichAbsPerc",),
    "str": ("RichEnum", "RichString", "RichOpenFile", "RichSaveFile"),
    "numpy.ndarray[numpy.float64[3]]": ("RichPosition", "RichPoint3f", "RichDirection"),
    "numpy.ndarray[numpy.float64[4, 4]]": ("RichMatrix44f",),
    "Color": ("RichColor",),
}

# pymeshlab filters that read or write files, or reach the network: a filter script is data from
# anyone, so none of them may run from one. Found by reading every filter's parameter list
# (``parameter_lists``) for file names (``input_file``, ``csvfilename``, ``imagefilename``,
# ``textname`` ...) and by their documentation; `touches_files` also refuses any filter with a
# parameter named like a file, so a filter added by a later pymeshlab is refused until checked.
FILE_FILTERS = frozenset({
    "nxs_build", "nxs_compress",  # read and write Nexus files
    "save_snapshot", "save_active_raster_cameras", "load_active_raster_cameras",
    "compute_color_from_scalar_using_transfer_function_per_vertex",  # reads a CSV transfer function
    "compute_color_and_texture_from_active_rasters_projection",  # writes a texture image
    "compute_texcoord_parametrization_and_texture_from_registered_rasters",  # writes a texture image
    "compute_texmap_from_color", "transfer_attributes_to_texture_per_vertex",  # write texture images
    "set_texture_per_mesh",  # reads or writes a texture image
    "export_mesh_to_sketchfab",  # uploads the mesh
})
_FILE_PARAM_RE = re.compile(r"file|path|folder|director|url|textname|texturename")
# .mlx parameter types that carry file names
FILE_TYPES = ("RichOpenFile", "RichSaveFile")


def touches_files(pname):
    """Whether pymeshlab's filter ``pname`` reads or writes files (see `FILE_FILTERS`)."""
    return pname in FILE_FILTERS or any(_FILE_PARAM_RE.search(k) for k in parameter_lists().get(pname, {}))


_HEADER_RE = re.compile(r"^(\w+) filter - list of parameter names:$")
_PARAM_RE = re.compile(r"^\t(\w+) : (.+?) = (.*)$")


# ---------------------------------------------------------------------------------------------
# names and parameter lists


def python_filter_name(meshlab_name):
    """pymeshlab's name of a MeshLab filter ('TwoStep Smooth' -> 'apply_coord_two_steps_smoothing'),
    or None if pymeshlab has no such filter.

    Most names lead to it as pymeshlab named its filters until 2022.2 (lowercased, words joined by
    '_') and its table of the renames since (keys.txt); a filter the table does not reach (added to
    MeshLab later, or renamed there: 'Re-Orient all faces coherently') is found by the name pymeshlab
    writes for it (`_written_name`).
    """
    renames, available = _pymeshlab_names()
    old = re.sub(r"[^0-9a-z]+", "_", meshlab_name.lower()).strip("_")
    new = renames.get(old, old)
    if new in available:
        return new
    return _written_name(meshlab_name)


@functools.lru_cache(maxsize=1)
def _pymeshlab_names():
    """pymeshlab's table of renamed filters (keys.txt: old derived name -> name) and its filter list."""
    pymeshlab = need("pymeshlab", "MeshLab's filters")

    renames = {}
    keys = os.path.join(os.path.dirname(pymeshlab.__file__), "keys.txt")
    if os.path.isfile(keys):
        with open(keys, encoding="utf-8") as f:
            for line in f:
                parts = line.split()
                if len(parts) == 2:
                    renames[parts[0]] = parts[1]
    return renames, frozenset(pymeshlab.filter_list())


# how many of pymeshlab's filters, likeliest first, are applied to find a MeshLab name (_written_name)
_CANDIDATES = 6


@functools.cache
def _written_name(meshlab_name):
    """pymeshlab's filter that writes ``meshlab_name`` into a script, among the filters likeliest to
    (`_likely_filters`); None if none does.

    pymeshlab tells a filter's MeshLab name only in the scripts it saves, so each candidate (files
    aside) is applied to a small sphere, else to the sphere with a hole (a parametrization needs a
    boundary), in a child process, and its name read from the script saved: the answer is
    pymeshlab's own. A filter that crashes pymeshlab there (one that needs OpenGL or cameras) or runs
    over 10 s is passed over. The first candidate that writes the name ends the search. About a
    second, once per process and name.
    """
    candidates = _likely_filters(meshlab_name)
    with temporary_folder("skelfilter-meshlab-names-") as work:
        with open(os.path.join(work, "names.json"), "w", encoding="utf-8") as f:
            json.dump({"wanted": meshlab_name, "candidates": candidates}, f)
        started = 0
        while started < len(candidates):
            try:
                proc = run_child(__name__, "_written_names_main", work, 120, "pymeshlab, writing filter names")
            except SkelfilterError:  # a filter crashed pymeshlab or hung: the next child passes it over
                proc = None
            now = len(_lines(os.path.join(work, "started")))
            if (proc is not None and proc.returncode == 0) or now == started:
                break
            started = now
        written = dict(json.loads(line) for line in _lines(os.path.join(work, "written.jsonl")))
    return written.get(meshlab_name)


def _likely_filters(meshlab_name):
    """The `_CANDIDATES` filters (files aside) whose pymeshlab names share the most words with
    ``meshlab_name``; words match on their first six letters ('developable', 'developability')."""
    def words(name):
        return {w for w in re.split(r"[^0-9a-z]+", name.lower()) if w}

    def same(a, b):
        n = min(len(a), len(b), 6)
        return a[:n] == b[:n] and (n >= 3 or a == b)

    wanted = words(meshlab_name)
    _, available = _pymeshlab_names()
    shared = {name: sum(any(same(w, v) for v in words(name)) for w in wanted) for name in available}
    ranked = sorted((name for name in shared if shared[name] and not touches_files(name)),
                    key=lambda name: (-shared[name], name))
    return ranked[:_CANDIDATES]


def _lines(path):
    try:
        with open(path, encoding="utf-8") as f:
            return f.read().splitlines()
    except FileNotFoundError:
        return []


def _written_names_main(workdir):
    """Entry point of `_written_name`'s child: names.json in (the name wanted, the candidates); each
    candidate appended to ``started`` before it is applied (so that the next child passes over one
    that crashed), and ``[MeshLab's name, pymeshlab's name]`` to written.jsonl once pymeshlab wrote
    it; ends at the name wanted."""
    import faulthandler

    pymeshlab = need("pymeshlab", "MeshLab's filters")

    with open(os.path.join(workdir, "names.json"), encoding="utf-8") as f:
        task = json.load(f)
    started = set(_lines(os.path.join(workdir, "started")))
    script = os.path.join(workdir, "written.mlx")
    for name in task["candidates"]:
        if name in started:
            continue
        with open(os.path.join(workdir, "started"), "a", encoding="utf-8") as f:
            f.write(name + "\n")
        for with_hole in (False, True):
            ms = pymeshlab.MeshSet()
            ms.create_sphere(subdiv=1)
            if with_hole:
                ms.compute_selection_by_condition_per_face(condselect="fi == 0")
                ms.meshing_remove_selected_faces()
            ms.clear_filter_script()
            faulthandler.dump_traceback_later(10, exit=True)
            try:
                getattr(ms, name)()
            except Exception:  # a mesh the filter cannot take (pymeshlab's exceptions share no base)
                continue
            finally:
                faulthandler.cancel_dump_traceback_later()
            ms.save_filter_script(script)
            written = mlx.parse(mlx.read_bytes(script), script)[-1].name
            with open(os.path.join(workdir, "written.jsonl"), "a", encoding="utf-8") as f:
                f.write(json.dumps([written, name]) + "\n")
            if written == task["wanted"]:
                return
            break


def python_param_name(meshlab_name):
    """pymeshlab's name of a parameter ('stepSmoothNum' -> 'stepsmoothnum', 'lambda' -> 'lambda_')."""
    name = re.sub(r"[^0-9a-z_]+", "_", meshlab_name.lower())
    return name + "_" if keyword.iskeyword(name) else name


@functools.lru_cache(maxsize=1)
def parameter_lists():
    """Every pymeshlab filter's parameters: ``{filter: {param: (type, default)}}``, as text.

    pymeshlab prints the lists from C++ (``print_filter_parameter_list``), so they are read from a
    child Python's output (half a second, once per process).
    """
    need("pymeshlab", "MeshLab's filters")
    code = ("import pymeshlab\n"
            "for name in pymeshlab.filter_list():\n"
            "    pymeshlab.print_filter_parameter_list(name)\n")
    try:
        proc = subprocess.run([sys.executable, "-c", code], stdin=subprocess.DEVNULL,
                              capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        raise SkelfilterError("pymeshlab did not list its filters' parameters within 120 s") from None
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["no message"])[-1]
        raise SkelfilterError(f"pymeshlab failed listing its filters' parameters: {last[-300:]}")
    lists, current = {}, None
    for line in proc.stdout.splitlines():
        header = _HEADER_RE.match(line)
        if header:
            current = lists.setdefault(header.group(1), {})
            continue
        param = _PARAM_RE.match(line)
        if param and current is not None:
            current[param.group(1)] = (param.group(2).strip(), param.group(3))
    return lists


def check_filter(element, pname, source):
    """The parameters of a MeshLab filter element, checked against pymeshlab's list of the filter.

    Parameters
    ----------
    element : mlx.FilterElement
    pname : str
        pymeshlab's name of the filter (:func:`python_filter_name`).
    source : str
        The script's name, for messages.

    Returns
    -------
    params : dict
        pymeshlab parameter name -> value the filter call takes.
    attrs : dict
        pymeshlab parameter name -> the <Param> attributes (what the child process is given).

    Raises
    ------
    InputError
        An unknown parameter, one given twice, a type that does not fit pymeshlab's, or a bad value;
        the message names the filter, the parameter and the line.
    """
    known = parameter_lists().get(pname, {})
    params, attrs = {}, {}
    for p in element.params:
        where = f"{source}:{p.line}: filter {element.name!r}, parameter {p.name!r}"
        key = python_param_name(p.name)
        if key not in known:
            raise InputError(f"{where}: unknown parameter (pymeshlab's {pname} takes "
                             f"{', '.join(known) or 'no parameters'})")
        if key in params:
            raise InputError(f"{where}: given twice")
        kind = known[key][0]
        allowed = _RICH_TYPES_OF.get(kind, ())
        if not allowed:
            raise InputError(f"{where}: pymeshlab cannot take a parameter of type {kind}")
        if p.attrs.get("type") not in allowed:
            raise InputError(f"{where}: wrong type {p.attrs.get('type')!r}; pymeshlab's {key} is of type "
                             f"{kind} ({' or '.join(allowed)})")
        params[key] = mlx.param_value(p.attrs, where)
        bounds = _BOUNDS_RE.search(known[key][1]) if kind == "float (bounded)" else None
        if bounds and not float(bounds[1]) <= params[key] <= float(bounds[2]):
            raise InputError(f"{where}: {p.attrs.get('value')} lies outside pymeshlab's range "
                             f"[{bounds[1]}, {bounds[2]}]")
        attrs[key] = p.attrs
    return params, attrs


_BOUNDS_RE = re.compile(r"\[min: ([^;\]]+); max: ([^\]]+)\]")  # pymeshlab's "128 [min: 0; max: 255]"


# ---------------------------------------------------------------------------------------------
# the child process


def _mesh_set(layers, current):
    pymeshlab = need("pymeshlab", "MeshLab's filters")

    ms = pymeshlab.MeshSet()
    for vertices, faces in layers:
        ms.add_mesh(pymeshlab.Mesh(vertex_matrix=vertices, face_matrix=faces))
    ms.set_current_mesh(current)
    return ms


def _layers(ms):
    """The (vertices, faces) of every layer of ``ms`` in id order, and the current one's position."""
    if ms.mesh_number() == 0:
        raise SkelfilterError("no layer is left")
    ids, i = [], 0
    while len(ids) < ms.mesh_number():
        if ms.mesh_id_exists(i):
            ids.append(i)
        i += 1
    layers = []
    for i in ids:
        mesh = ms.mesh(i)
        if not mesh.is_compact():
            mesh.compact()
        layers.append((mesh.vertex_matrix(), mesh.face_matrix()))
    return layers, ids.index(ms.current_mesh_id())


def apply_filter(ms, pname, params):
    """Apply one pymeshlab filter to ``ms`` (MLS projections the safe way); returns the MeshSet."""
    if pname not in MLS_FILTERS:
        getattr(ms, pname)(**params)
        return ms
    pymeshlab = need("pymeshlab", "MeshLab's filters")

    layers, current = _layers(ms)
    safe = _mesh_set([layers[current]], 0)
    safe.compute_normal_per_vertex()
    vertices, faces = layers[current]
    safe.add_mesh(pymeshlab.Mesh(vertex_matrix=vertices, face_matrix=faces))
    safe.set_current_mesh(0)
    getattr(safe, pname)(**dict(params, controlmesh=0, proxymesh=1))
    layers[current] = _layers(safe)[0][1]
    return _mesh_set(layers, current)


def _save_layers(path, layers, current):
    arrays = {"current": np.array(current)}
    for i, (vertices, faces) in enumerate(layers):
        arrays[f"v{i}"] = np.ascontiguousarray(vertices, dtype=np.float64)
        arrays[f"f{i}"] = np.ascontiguousarray(faces, dtype=np.int32).reshape(-1, 3)
    np.savez(path, count=np.array(len(layers)), **arrays)


def _load_layers(path):
    with np.load(path) as z:
        return [(z[f"v{i}"], z[f"f{i}"]) for i in range(int(z["count"]))], int(z["current"])


def _child_main(workdir):
    """Entry point of the child process: steps.json and layers.npz in, result.npz (or error.json) out.

    Before each step its position goes to the file ``step``, so that a crash or a hang can be
    told apart from the other steps'."""
    with open(os.path.join(workdir, "steps.json"), encoding="utf-8") as f:
        steps = json.load(f)
    ms = _mesh_set(*_load_layers(os.path.join(workdir, "layers.npz")))
    for i, step in enumerate(steps):
        with open(os.path.join(workdir, "step"), "w", encoding="utf-8") as f:
            f.write(str(i))
        try:
            params = {k: mlx.param_value(a, step["name"]) for k, a in step["params"].items()}
            ms = apply_filter(ms, step["name"], params)
            layers, current = _layers(ms)
        except Exception as exc:
            _child_fails(workdir, i, f"{type(exc).__name__}: {exc}")
        vertices = layers[current][0]
        bad = int((~np.isfinite(vertices).all(axis=1)).sum())
        if bad:
            _child_fails(workdir, i, f"the result has {bad} of {len(vertices)} vertices with NaN or infinite "
                         "coordinates")
    _save_layers(os.path.join(workdir, "result.npz"), layers, current)


def _child_fails(workdir, step, error):
    with open(os.path.join(workdir, "error.json"), "w", encoding="utf-8") as f:
        json.dump({"step": step, "error": error}, f)
    sys.exit(3)


def _running_step(workdir, steps):
    """The step the child was at when it stopped (the first if it never started one)."""
    try:
        with open(os.path.join(workdir, "step"), encoding="utf-8") as f:
            return steps[int(f.read())]
    except (OSError, ValueError, IndexError):
        return steps[0]


def run_filters(layers, current, steps, timeout=300):
    """Apply MeshLab filters to a stack of layers with pymeshlab, in a child process.

    Parameters
    ----------
    layers : list of (vertices, faces)
        Every layer, as float64 (n, 3) and int (m, 3) arrays.
    current : int
        Position of the current layer, which the filters act on.
    steps : list of (str, dict, str)
        pymeshlab filter name, its ``<Param>`` attributes by pymeshlab parameter name (see
        :func:`check_filter`), and how messages name the step.
    timeout : float
        Seconds before the child is killed.

    Returns
    -------
    (list of (vertices, faces), int)
        Every layer after the filters, in id order, and the current one's position.

    Raises
    ------
    SkelfilterError
        The child crashed (the signal is named), timed out, or a filter raised (the step is named).
    """
    with temporary_folder("skelfilter-meshlab-") as work:
        with open(os.path.join(work, "steps.json"), "w", encoding="utf-8") as f:
            json.dump([{"name": name, "params": attrs} for name, attrs, _ in steps], f)
        _save_layers(os.path.join(work, "layers.npz"), layers, current)
        def running():
            name, _, where = _running_step(work, steps)
            return f"{where} (pymeshlab's {name})"

        proc = run_child("skelfilter.meshlab.pymeshlab_filters", "_child_main", work, timeout, running)
        error_file = os.path.join(work, "error.json")
        if os.path.exists(error_file):
            with open(error_file, encoding="utf-8") as f:
                error = json.load(f)
            name, _, where = steps[error["step"]]
            details = "; ".join(line.strip() for line in str(error["error"]).splitlines() if line.strip())
            raise SkelfilterError(f"{where}: pymeshlab's {name} failed: {details}")
        if proc.returncode != 0:
            tail = proc.stderr.decode("utf-8", "replace").strip().splitlines()[-3:]
            raise SkelfilterError(f"{running()}: the child process failed (exit status "
                                  f"{proc.returncode}): {' | '.join(tail)}")
        return _load_layers(os.path.join(work, "result.npz"))
