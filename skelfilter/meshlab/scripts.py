"""MeshLab filter scripts (.mlx) mixing MeshLab's filters and skelfilter's: read, run, write.

A script is read safely (:mod:`skelfilter.meshlab.mlx`) and checked whole before anything runs: every filter
is a skelfilter filter (:mod:`skelfilter.meshlab.descriptions`, by its MeshLab name) or one that pymeshlab has,
every parameter is one the filter takes, of its type (and, for skelfilter's, in its range). An error
names the script's line, the filter and the parameter.

Running keeps MeshLab's layers: a list of meshes and the current one. Consecutive MeshLab filters run
together in one pymeshlab child process (:func:`skelfilter.meshlab.pymeshlab_filters.run_filters`), which gets
and gives back every layer, so a filter that creates a layer makes it current as in MeshLab.
skelfilter's filters run in this process on the current layer and add their result as a new layer,
which becomes current: what MeshLab's remeshing filters (Screened Poisson, Marching Cubes) do. The
result of a script is its current layer.
"""

import itertools
from dataclasses import dataclass

import numpy as np
import trimesh

from skelfilter.errors import InputError, ParameterError, SkelfilterError
from skelfilter.io import mesh_files, output_files
from skelfilter.meshlab import descriptions, filter_catalogue, mlx, pymeshlab_filters
from skelfilter.runtime.progress import Progress


@dataclass
class Step:
    """One checked filter of a script."""

    name: str  # pymeshlab's name of a MeshLab filter, or the Python name of a skelfilter filter
    params: dict  # by parameter name: what the pymeshlab call takes, or the skelfilter dataclass fields
    where: str  # how messages name it: "script.mlx:4: filter 'Taubin Smooth'"
    attrs: dict  # a MeshLab filter's <Param> attributes by pymeshlab name (what its child is given)
    filter: descriptions.FilterDescription = None  # skelfilter's filter; None for MeshLab's


@dataclass
class Layers:
    """MeshLab's layers: every mesh, and the position of the current one."""

    meshes: list
    current: int

    @property
    def current_mesh(self):
        return self.meshes[self.current]


# ---------------------------------------------------------------------------------------------
# reading


def _check_skelfilter(element, description, source):
    where = f"{source}:{element.line}: filter {element.name!r}"
    values = {}
    for p in element.params:
        at = f"{source}:{p.line}: filter {element.name!r}, parameter {p.name!r}"
        try:
            param = description.parameter(p.name)
        except ParameterError:
            raise InputError(f"{at}: unknown parameter ({description.name} takes "
                             f"{', '.join(q.name for q in description.parameters)})") from None
        if p.name in values:
            raise InputError(f"{at}: given twice")
        if p.attrs.get("type") != param.rich_type:
            raise InputError(f"{at}: wrong type {p.attrs.get('type')!r}; {p.name} is a {param.rich_type}")
        try:
            values[p.name] = param.to_python(mlx.param_value(p.attrs, at))
        except ParameterError as exc:
            raise InputError(f"{at}: {exc}") from None
    try:
        params = description.params_class(**values)
    except ParameterError as exc:
        raise InputError(f"{where}: {exc}") from None
    return Step(description.python_name, {p.name: getattr(params, p.name) for p in description.parameters},
                where, {}, description)


def _check(element, source):
    for description in descriptions.FILTERS:
        if element.name == description.name:
            return _check_skelfilter(element, description, source)
    where = f"{source}:{element.line}: filter {element.name!r}"
    pname = filter_catalogue.python_filter_name(element.name)
    if pname is None:
        raise InputError(f"{where}: unknown filter: not a skelfilter filter "
                         f"({', '.join(d.name for d in descriptions.FILTERS)}) and not available in pymeshlab")
    if filter_catalogue.touches_files(pname):
        raise InputError(f"{where}: reads or writes files; not allowed in scripts")
    for p in element.params:
        if p.attrs.get("type") in filter_catalogue.FILE_TYPES:
            raise InputError(f"{source}:{p.line}: filter {element.name!r}, parameter {p.name!r}: a file name "
                             f"({p.attrs.get('type')}); not allowed in scripts")
    params, attrs = pymeshlab_filters.check_filter(element, pname, source)
    return Step(pname, params, where, attrs)


def read_script(path):
    """Read and check a MeshLab ``.mlx`` filter script.

    Returns
    -------
    list of Step
        In script order.

    Raises
    ------
    InputError
        Missing file, over 1 MiB, a DOCTYPE with declarations or an external reference, any entity
        declaration, malformed XML, an unknown filter or parameter, a wrong type or a value out of
        range; the message names the line (and the filter and parameter).
    """
    source = str(path)
    return [_check(element, source) for element in mlx.parse(mlx.read_bytes(path), source)]


def read_filter_script(path):
    """The filters of a ``.mlx`` script: ``[(name, params), ...]`` in script order.

    ``name`` is pymeshlab's name of a MeshLab filter (``params``: what ``getattr(ms, name)(**params)``
    takes) or the Python name of a skelfilter filter (``params``: its dataclass fields); see
    :func:`read_script` for the checks.
    """
    return [(step.name, step.params) for step in read_script(path)]


# ---------------------------------------------------------------------------------------------
# running


def _run_meshlab(layers, steps, timeout):
    arrays = [(np.asarray(m.vertices, dtype=np.float64), np.asarray(m.faces)) for m in layers.meshes]
    out, current = pymeshlab_filters.run_filters(
        arrays, layers.current, [(s.name, s.attrs, s.where) for s in steps], timeout)
    return Layers([trimesh.Trimesh(vertices=v, faces=f, process=False) for v, f in out], current)


def _run_skelfilter(layers, step, progress):
    mesh = mesh_files.validate_mesh(layers.current_mesh, f"{step.where}: the current layer")
    params = step.filter.params_class(**step.params)
    with progress.stage(step.filter.name):
        try:
            result = step.filter.apply(mesh, params, progress)
        except SkelfilterError as exc:
            raise type(exc)(f"{step.where}: {exc}") from None
    return Layers(layers.meshes + [result], len(layers.meshes))


def run_steps(steps, mesh, timeout=300, progress=None):
    """Run checked script steps on a mesh, with MeshLab's layers.

    Parameters
    ----------
    steps : list of Step
        From :func:`read_script`.
    mesh : trimesh.Trimesh
        Layer 0, current at the start.
    timeout : float
        Seconds each run of consecutive MeshLab filters may take in its child process.
    progress : Progress, optional

    Returns
    -------
    Layers
        Every layer; the script's result is ``current_mesh``.

    Raises
    ------
    SkelfilterError
        A filter failed (the step's line and filter are named), pymeshlab crashed or timed out, a
        result has NaN vertices.
    """
    mesh = mesh_files.validate_mesh(mesh, "mesh")
    progress = progress or Progress(enabled=False)
    layers = Layers([mesh], 0)
    for is_meshlab, run in itertools.groupby(steps, key=lambda step: step.filter is None):
        run = list(run)
        if is_meshlab:
            with progress.step(f"MeshLab: {', '.join(step.name for step in run)}", shield=False):
                layers = _run_meshlab(layers, run, timeout)
            continue
        for step in run:
            layers = _run_skelfilter(layers, step, progress)
    return layers


def run_filter_script(mesh, path, timeout=300):
    """Apply a ``.mlx`` script to ``mesh``; returns the current layer at the end.

    MeshLab's filters run in pymeshlab in child processes (a crash, a timeout or NaN vertices come
    back as a :class:`~skelfilter.errors.SkelfilterError`); vertices and faces come out as pymeshlab
    gives them (no merging or reordering). See :func:`read_script` and :func:`run_steps`.
    """
    return run_steps(read_script(path), mesh, timeout).current_mesh


# ---------------------------------------------------------------------------------------------
# writing


def filter_element(description, params):
    """The ``<filter>`` of a skelfilter filter with the parameters ``params`` (its dataclass)."""
    elements = []
    for p in description.parameters:
        value = p.to_meshlab(getattr(params, p.name))
        attrs = {"name": p.name, "type": p.rich_type, "description": p.description,
                 "tooltip": p.full_tooltip}
        if p.choices:
            attrs["value"] = str(p.choices.index(value))
            attrs.update({f"enum_val{i}": choice for i, choice in enumerate(p.choices)})
            attrs["enum_cardinality"] = str(len(p.choices))
        else:
            attrs["value"] = mlx.format_value(value)
        elements.append(mlx.ParamElement(attrs, 0))
    return mlx.FilterElement(description.name, 0, elements)


def export_script(path, description, params, protect=()):
    """Write a ``.mlx`` script applying one skelfilter filter with ``params``, atomically."""
    if not str(path).lower().endswith(".mlx"):
        raise InputError(f"{path}: a filter script's name ends in .mlx")
    output_files.write_bytes(path, mlx.script_text([filter_element(description, params)]).encode("utf-8"), protect)
