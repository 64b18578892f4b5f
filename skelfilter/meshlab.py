"""MeshLab filter scripts (.mlx): read them safely and run them through pymeshlab in a child process.

``read_filter_script(path)`` turns the XML that MeshLab and pymeshlab's ``save_filter_script`` write
into ``[(pymeshlab_filter_name, {param: value}), ...]``, the values being what the pymeshlab filter
call accepts (``getattr(ms, name)(**params)``). ``run_filter_script(mesh, path)`` applies the script
to a trimesh mesh in a separate Python process, so a crash in MeshLab's C++ code (segmentation
fault, abort) or a hang becomes a :class:`~skelfilter.errors.SkelfilterError` instead of killing the
caller.

The MLS projections (APSS, RIMLS) crash when the mesh is projected onto itself (both layers 0, the
default). The runner always applies them the way that works: layer 0 is the mesh with freshly computed
per-vertex normals (the point set defining the MLS surface), layer 1 a copy of it that is projected,
``controlmesh=0, proxymesh=1``; the result is layer 1. The script's own ControlMesh/ProxyMesh values
are ignored (the runner works on a single mesh).
"""

import functools
import keyword
import os
import re
import signal
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

import numpy as np
import trimesh

from .errors import InputError, SkelfilterError

MAX_SCRIPT_BYTES = 1 << 20

MLS_FILTERS = ("compute_mls_projection_apss", "compute_mls_projection_rimls")

# hidden hook for the tests: the child aborts ("abort") or hangs ("sleep") before doing any work
_TEST_HOOK_ENV = "_SKELFILTER_MESHLAB_CHILD_HOOK"

_DOCTYPE_RE = re.compile(rb"<!DOCTYPE\b[^>]*>", re.IGNORECASE)
_PLAIN_DOCTYPE_RE = re.compile(rb"<!DOCTYPE\s+FilterScript\s*>")


# ---------------------------------------------------------------------------------------------
# reading


def _read_bytes(path):
    path = str(path)
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such filter script")
    size = os.path.getsize(path)
    if size > MAX_SCRIPT_BYTES:
        raise InputError(f"{path}: filter script is {size} bytes, more than the 1 MiB accepted")
    with open(path, "rb") as f:
        data = f.read(MAX_SCRIPT_BYTES + 1)
    if len(data) > MAX_SCRIPT_BYTES:
        raise InputError(f"{path}: filter script is more than the 1 MiB accepted")
    return data


def _check_markup(data, name):
    """Refuse entity declarations and any DOCTYPE other than MeshLab's bare ``<!DOCTYPE FilterScript>``."""
    if re.search(rb"<!ENTITY", data, re.IGNORECASE):
        raise InputError(f"{name}: filter script declares XML entities (<!ENTITY>), refused")
    doctypes = _DOCTYPE_RE.findall(data)
    if re.search(rb"<!DOCTYPE", data, re.IGNORECASE) and not doctypes:
        raise InputError(f"{name}: filter script has a malformed DOCTYPE declaration, refused")
    for d in doctypes:
        if not _PLAIN_DOCTYPE_RE.fullmatch(d):
            raise InputError(f"{name}: filter script has a DOCTYPE with declarations or an external "
                             f"reference ({d[:60].decode('ascii', 'replace')}...), refused")
    if len(doctypes) > 1:
        raise InputError(f"{name}: filter script has more than one DOCTYPE declaration, refused")


def _python_filter_name(meshlab_name):
    """pymeshlab's name of a MeshLab filter, e.g. 'TwoStep Smooth' -> 'apply_coord_two_steps_smoothing'."""
    renames, available = _pymeshlab_names()
    old = re.sub(r"[^0-9a-z]+", "_", meshlab_name.lower()).strip("_")
    new = renames.get(old, old)
    return new if new in available else None


@functools.lru_cache(maxsize=1)
def _pymeshlab_names():
    """pymeshlab's table of renamed filters (keys.txt: old derived name -> name) and its filter list."""
    import pymeshlab

    renames = {}
    keys = os.path.join(os.path.dirname(pymeshlab.__file__), "keys.txt")
    if os.path.isfile(keys):
        with open(keys, encoding="utf-8") as f:
            for line in f:
                parts = line.split()
                if len(parts) == 2:
                    renames[parts[0]] = parts[1]
    return renames, frozenset(pymeshlab.filter_list())


def _python_param_name(meshlab_name):
    name = re.sub(r"[^0-9a-z_]+", "_", meshlab_name.lower())
    return name + "_" if keyword.iskeyword(name) else name


def _float(attrs, key, where):
    try:
        v = float(attrs[key])
    except KeyError:
        raise InputError(f"{where}: attribute {key!r} missing") from None
    except ValueError:
        raise InputError(f"{where}: {key}={attrs[key]!r} is not a number") from None
    if not np.isfinite(v):
        raise InputError(f"{where}: {key}={attrs[key]!r} is not finite")
    return v


def _param_value(attrs, where):
    """Value of one <Param> element, as the pymeshlab filter call accepts it."""
    import pymeshlab

    kind = attrs.get("type")
    value = attrs.get("value")
    if kind == "RichBool":
        if value is None or value.lower() not in ("true", "false"):
            raise InputError(f"{where}: RichBool value {value!r} is not true/false")
        return value.lower() == "true"
    if kind in ("RichInt", "RichMesh"):
        try:
            return int(value)
        except (TypeError, ValueError):
            raise InputError(f"{where}: {kind} value {value!r} is not an integer") from None
    if kind in ("RichFloat", "RichDynamicFloat"):
        return _float(attrs, "value", where)
    if kind == "RichAbsPerc":
        # saved as an absolute length for the mesh the script was made on; pymeshlab (like MeshLab)
        # reads it back as the same fraction of the [min, max] range, i.e. of the bounding-box diagonal
        v, lo, hi = (_float(attrs, k, where) for k in ("value", "min", "max"))
        if hi > lo:
            return pymeshlab.PercentageValue(100.0 * (v - lo) / (hi - lo))
        return pymeshlab.PureValue(v)
    if kind == "RichEnum":
        try:
            index = int(value)
        except (TypeError, ValueError):
            raise InputError(f"{where}: RichEnum value {value!r} is not an integer") from None
        label = attrs.get(f"enum_val{index}")
        if label is None:
            raise InputError(f"{where}: RichEnum value {index} has no enum_val{index}")
        return label
    if kind in ("RichPosition", "RichPoint3f", "RichDirection"):
        return np.array([_float(attrs, k, where) for k in ("x", "y", "z")])
    if kind == "RichMatrix44f":
        return np.array([_float(attrs, f"val{i}", where) for i in range(16)]).reshape(4, 4)
    if kind == "RichColor":
        r, g, b, a = (int(_float(attrs, k, where)) for k in "rgba")
        return pymeshlab.Color(r, g, b, a)
    if kind in ("RichString", "RichOpenFile", "RichSaveFile"):
        if value is None:
            raise InputError(f"{where}: {kind} has no value")
        return value
    raise InputError(f"{where}: parameter type {kind!r} is not supported")


def _parse(data, name):
    _check_markup(data, name)
    # the (checked, bare) DOCTYPE carries nothing; drop it so expat never sees a DTD
    data = _DOCTYPE_RE.sub(b"", data)
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise InputError(f"{name}: malformed filter script XML ({exc})") from None
    if root.tag != "FilterScript":
        raise InputError(f"{name}: root element is <{root.tag}>, not <FilterScript>")
    filters = []
    for i, el in enumerate(root):
        if el.tag != "filter":
            raise InputError(f"{name}: element {i} is <{el.tag}>; only <filter> elements are supported")
        mname = el.get("name")
        if not mname:
            raise InputError(f"{name}: filter {i} has no name")
        pname = _python_filter_name(mname)
        if pname is None:
            raise InputError(f"{name}: filter {mname!r} is not available in pymeshlab")
        params = {}
        for p in el:
            if p.tag != "Param" or not p.get("name"):
                raise InputError(f"{name}: filter {mname!r} has an unexpected <{p.tag}> element")
            params[_python_param_name(p.get("name"))] = _param_value(
                p.attrib, f"{name}: filter {mname!r}, parameter {p.get('name')!r}")
        filters.append((pname, params))
    if not filters:
        raise InputError(f"{name}: filter script contains no filters")
    return filters


def read_filter_script(path):
    """Parse a MeshLab ``.mlx`` filter script.

    Returns
    -------
    list of (str, dict)
        pymeshlab filter name and its parameters (pymeshlab names and value types), in script order.

    Raises
    ------
    InputError
        Missing file, over 1 MiB, a DOCTYPE with declarations or any ENTITY declaration, malformed
        XML, unknown filter or parameter type.
    """
    return _parse(_read_bytes(path), str(path))


# ---------------------------------------------------------------------------------------------
# running


def _apply(ms, pname, params):
    """Apply one filter to the single mesh in ``ms``; returns the MeshSet holding the result."""
    import pymeshlab

    if pname in MLS_FILTERS:
        mesh = ms.current_mesh()
        v, f = mesh.vertex_matrix(), mesh.face_matrix()
        safe = pymeshlab.MeshSet()
        safe.add_mesh(pymeshlab.Mesh(vertex_matrix=v, face_matrix=f))
        safe.compute_normal_per_vertex()
        safe.add_mesh(pymeshlab.Mesh(vertex_matrix=v, face_matrix=f))
        safe.set_current_mesh(0)
        getattr(safe, pname)(**dict(params, controlmesh=0, proxymesh=1))
        out = safe.mesh(1)
        ms = pymeshlab.MeshSet()
        ms.add_mesh(pymeshlab.Mesh(vertex_matrix=out.vertex_matrix(), face_matrix=out.face_matrix()))
        return ms
    getattr(ms, pname)(**params)
    return ms


def _child_main(workdir):
    """Entry point of the child process: reads mesh.npz and script.mlx, writes result.npz."""
    hook = os.environ.get(_TEST_HOOK_ENV)
    if hook == "abort":
        os.abort()
    if hook == "sleep":
        import time

        time.sleep(3600)
    import pymeshlab

    with open(os.path.join(workdir, "script.mlx"), "rb") as f:
        filters = _parse(f.read(), "script")
    with np.load(os.path.join(workdir, "mesh.npz")) as z:
        vertices, faces = z["vertices"], z["faces"]
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=vertices, face_matrix=faces))
    for pname, params in filters:
        try:
            ms = _apply(ms, pname, params)
        except Exception as exc:
            with open(os.path.join(workdir, "error.txt"), "w", encoding="utf-8") as f:
                f.write(f"{pname}: {type(exc).__name__}: {exc}")
            sys.exit(3)
    mesh = ms.current_mesh()
    if not mesh.is_compact():
        mesh.compact()
    np.savez(os.path.join(workdir, "result.npz"),
             vertices=mesh.vertex_matrix(), faces=mesh.face_matrix())


def signal_text(code):
    try:
        return f"{signal.strsignal(code) or signal.Signals(code).name} (signal {code})"
    except (ValueError, AttributeError):
        return f"signal {code}"


def run_filter_script(mesh, path, timeout=300):
    """Apply the filters of a MeshLab ``.mlx`` script to ``mesh`` with pymeshlab, in a child process.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    path : str or path
        The filter script (parsed and checked here first, see :func:`read_filter_script`).
    timeout : float
        Seconds before the child is killed.

    Returns
    -------
    trimesh.Trimesh
        pymeshlab's vertices and faces as they come out (``process=False``: no merging or reordering).

    Raises
    ------
    InputError
        Bad script (see :func:`read_filter_script`) or unusable mesh.
    SkelfilterError
        The child crashed (the signal is named), timed out, a filter raised, or the result has
        non-finite vertices or no faces.
    """
    data = _read_bytes(path)
    filters = _parse(data, str(path))
    names = ", ".join(p for p, _ in filters)
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise InputError("mesh: the mesh is empty (no triangles)")
    if not np.isfinite(mesh.vertices).all():
        raise InputError("mesh: vertex coordinates contain NaN or infinity")

    package_parent = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_parent, env.get("PYTHONPATH")) if p)
    with tempfile.TemporaryDirectory(prefix="skelfilter-meshlab-") as work:
        with open(os.path.join(work, "script.mlx"), "wb") as f:
            f.write(data)
        np.savez(os.path.join(work, "mesh.npz"),
                 vertices=np.ascontiguousarray(mesh.vertices, dtype=np.float64),
                 faces=np.ascontiguousarray(mesh.faces, dtype=np.int32))
        cmd = [sys.executable, "-c",
               "import sys; from skelfilter.meshlab import _child_main; _child_main(sys.argv[1])", work]
        try:
            proc = subprocess.run(cmd, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                  stderr=subprocess.PIPE, timeout=timeout)
        except subprocess.TimeoutExpired:
            raise SkelfilterError(f"{path}: MeshLab filters ({names}) did not finish within "
                                  f"{timeout:g} s; the child process was killed") from None
        if proc.returncode < 0:
            raise SkelfilterError(f"{path}: pymeshlab crashed running {names}: "
                                  f"{signal_text(-proc.returncode)}")
        error_file = os.path.join(work, "error.txt")
        if os.path.exists(error_file):
            with open(error_file, encoding="utf-8") as f:
                raise SkelfilterError(f"{path}: filter {f.read()}")
        if proc.returncode != 0:
            tail = proc.stderr.decode("utf-8", "replace").strip().splitlines()[-3:]
            raise SkelfilterError(f"{path}: the pymeshlab child process failed (exit status "
                                  f"{proc.returncode}): {' | '.join(tail)}")
        with np.load(os.path.join(work, "result.npz")) as z:
            vertices, faces = z["vertices"], z["faces"]
    if len(faces) == 0:
        raise SkelfilterError(f"{path}: the filters ({names}) returned a mesh without faces")
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise SkelfilterError(f"{path}: the filters ({names}) returned {int(bad.sum())} of "
                              f"{len(vertices)} vertices with NaN or infinite coordinates")
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
