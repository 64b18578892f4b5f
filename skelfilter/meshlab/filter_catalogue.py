"""pymeshlab's filters as a catalogue: their MeshLab names, their parameter lists, which touch files.

A MeshLab filter in a script is named as MeshLab shows it ("Taubin Smooth"); pymeshlab calls it
``apply_coord_taubin_smoothing`` (`python_filter_name`) and lowercases its parameter names
(`python_param_name`); `parameter_lists` is every filter's parameters as pymeshlab prints them. A
filter that reads or writes files may not run from a script (`touches_files`): a filter script is
data from anyone.
"""

import functools
import json
import keyword
import os
import re
import subprocess
import sys

from skelfilter.errors import SkelfilterError
from skelfilter.meshlab import mlx
from skelfilter.runtime.child import run_child
from skelfilter.runtime.extras import need
from skelfilter.runtime.signals import temporary_folder

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


_HEADER_RE = re.compile(r"^(\w+) filter - list of parameter names:$")
_PARAM_RE = re.compile(r"^\t(\w+) : (.+?) = (.*)$")


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
