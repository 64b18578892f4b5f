"""MeshLab's filters as pymeshlab runs them: a script's filter checked, and a crash-safe child process.

:func:`check_filter` checks every parameter's name and .mlx type of a script's filter against
pymeshlab's own parameter list of the filter (`filter_catalogue.parameter_lists`, what
``pymeshlab.print_filter_parameter_list`` prints).

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

import json
import os
import re
import sys

import numpy as np

from skelfilter.errors import InputError, SkelfilterError
from skelfilter.meshlab import mlx
from skelfilter.meshlab.filter_catalogue import parameter_lists, python_param_name
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

# ---------------------------------------------------------------------------------------------
# checking a filter of a script


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
