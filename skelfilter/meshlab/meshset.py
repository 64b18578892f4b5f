"""skelfilter's filters on a PyMeshLab ``MeshSet``, in PyMeshLab's style.

::

    import pymeshlab
    from skelfilter.meshlab import meshset

    ms = pymeshlab.MeshSet()
    ms.load_new_mesh("noisy.ply")
    meshset.apply_skeleton_saliency_denoise(ms, resolution=192, threshold=12)
    ms.save_current_mesh("clean.ply")

Each function works on the current mesh and adds its result as a new layer, which becomes current, as
MeshLab's remeshing filters do; the input layer is left as it is. Its keyword arguments, defaults and
docstring are those of the filter's description (:mod:`skelfilter.meshlab.descriptions`); 0 or None leaves an
optional parameter unset. :func:`register` also binds them as ``MeshSet`` methods
(``ms.apply_skeleton_saliency_denoise(threshold=12)``), the way pymeshlab binds its own filters.
"""

import inspect

import numpy as np
import trimesh

from skelfilter.errors import InputError
from skelfilter.io import mesh_files
from skelfilter.meshlab.descriptions import ADD_SKELETON_NOISE, FILTERS, SKELETON_SALIENCY_DENOISE
from skelfilter.runtime.extras import need


def to_trimesh(mesh):
    """A ``pymeshlab.Mesh`` as a ``trimesh.Trimesh``: same vertices and faces, in the same order, and
    its per-vertex or per-face colours.

    A mesh with deleted elements is compacted first (pymeshlab gives no matrices otherwise).
    """
    if not mesh.is_compact():
        mesh.compact()
    out = trimesh.Trimesh(vertices=mesh.vertex_matrix(), faces=mesh.face_matrix(), process=False)
    if mesh.has_vertex_color():
        out.visual.vertex_colors = np.round(mesh.vertex_color_matrix() * 255).astype(np.uint8)
    elif mesh.has_face_color():
        out.visual.face_colors = np.round(mesh.face_color_matrix() * 255).astype(np.uint8)
    return out


def to_pymeshlab(mesh):
    """A ``trimesh.Trimesh`` as a ``pymeshlab.Mesh``: same vertices and faces, in the same order, and
    its per-vertex or per-face colours."""
    pymeshlab = need("pymeshlab", "a PyMeshLab MeshSet")

    colours = {}
    kind = getattr(mesh.visual, "kind", None)
    if kind == "vertex":
        colours["v_color_matrix"] = np.asarray(mesh.visual.vertex_colors, dtype=np.float64) / 255
    elif kind == "face":
        colours["f_color_matrix"] = np.asarray(mesh.visual.face_colors, dtype=np.float64) / 255
    return pymeshlab.Mesh(vertex_matrix=np.asarray(mesh.vertices, dtype=np.float64),
                          face_matrix=np.asarray(mesh.faces, dtype=np.int32), **colours)


def _docstring(description):
    lines = [f"{description.name}: {description.description}", "", "Parameters", "----------",
             "ms : pymeshlab.MeshSet",
             "    Its current mesh is filtered; the result is added as a new layer and made current."]
    for p in description.parameters:
        kind = f"{p.value_type.__name__}" + (", optional" if p.optional else "")
        lines += [f"{p.name} : {kind}, default {p.default!r}", f"    {p.description}: {p.full_tooltip}"]
    lines += ["", "Raises", "------", "ParameterError",
              "    Unknown parameter, wrong type or value out of range.",
              "InputError", "    The current mesh has no triangles or non-finite vertices."]
    lines += ["", "Examples", "--------",
              ">>> import pymeshlab, trimesh",
              ">>> from skelfilter.meshlab import meshset",
              ">>> ms = pymeshlab.MeshSet()",
              ">>> ms.add_mesh(meshset.to_pymeshlab(trimesh.creation.icosphere(subdivisions=3)))",
              f">>> meshset.{description.python_name}(ms)",
              ">>> ms.mesh_number(), ms.current_mesh_id()  # the result: a new layer, made current",
              "(2, 1)"]
    return "\n".join(lines)


def _meshset_function(description):
    def apply(ms, /, **params):
        settings = description.make_params(**params)
        if ms.mesh_number() == 0:
            raise InputError("the MeshSet is empty: add a mesh first (ms.load_new_mesh or ms.add_mesh)")
        mesh = mesh_files.validate_mesh(to_trimesh(ms.current_mesh()), "the current mesh")
        result = description.apply(mesh, settings)
        ms.add_mesh(to_pymeshlab(result), mesh_name=description.layer, set_as_current=True)

    apply.__name__ = apply.__qualname__ = description.python_name
    apply.__doc__ = _docstring(description)
    apply.__signature__ = inspect.Signature(
        [inspect.Parameter("ms", inspect.Parameter.POSITIONAL_ONLY)]
        + [inspect.Parameter(p.name, inspect.Parameter.KEYWORD_ONLY, default=p.default)
           for p in description.parameters])
    return apply


_FUNCTIONS = {d.python_name: _meshset_function(d) for d in FILTERS}
apply_skeleton_saliency_denoise = _FUNCTIONS[SKELETON_SALIENCY_DENOISE.python_name]
apply_skeleton_noise = _FUNCTIONS[ADD_SKELETON_NOISE.python_name]


def register():
    """Bind the functions as ``pymeshlab.MeshSet`` methods, next to pymeshlab's own filters."""
    pymeshlab = need("pymeshlab", "a PyMeshLab MeshSet")

    for name, function in _FUNCTIONS.items():
        setattr(pymeshlab.MeshSet, name, function)
