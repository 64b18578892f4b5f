"""Regenerate the filter scripts: the MeshLab baselines of the comparison (thesis §8.2.1), shipped in
the package (``skelfilter/evaluation/comparison/scripts``), and in this folder ``skeleton_denoise.mlx`` and the
mixed example. Run: ``python meshlab_scripts/make_scripts.py``.

Each baseline script is written by pymeshlab's own ``MeshSet.save_filter_script`` after applying its
filter to a small mesh, so the XML is exactly what pymeshlab/MeshLab write.

The MLS projections (APSS, RIMLS) crash when a mesh is projected onto itself, so they are applied the
safe way: layer 0 with per-vertex normals is the point set, layer 1 a copy that is projected
(``controlmesh=0, proxymesh=1``). The normal computation is cleared from the recorded script, which
therefore holds only the MLS filter with ControlMesh 0 and ProxyMesh 1.

``skeleton_denoise.mlx`` applies "Skeleton Saliency Denoise" with the default preset, as
``skelfilter export-script denoise`` writes it. ``mixed_example.mlx`` cleans the mesh up with MeshLab's
filters, denoises it with skelfilter's and smooths it lightly with MeshLab's Taubin filter; its MeshLab
filters are taken from a script pymeshlab saved. Both are written with skelfilter's writer, which
orders the attributes, so the same parameters always give the same file.
"""

import os
import tempfile

import pymeshlab
import trimesh

from skelfilter.meshlab import mlx, scripts
from skelfilter.meshlab.descriptions import SKELETON_SALIENCY_DENOISE
from skelfilter.params import DenoiseParams

HERE = os.path.dirname(os.path.abspath(__file__))
BASELINES = os.path.join(os.path.dirname(HERE), "skelfilter", "evaluation", "comparison", "scripts")

SMOOTHING = {
    # thesis §8.2.1: max normal deviation 60 deg, 50 iterations
    "laplacian_surface_preserving.mlx": (
        "apply_coord_laplacian_smoothing_surface_preserving", dict(angledeg=60, iterations=50)),
    # smoothing steps 40, feature angle 60 deg, normal smoothing steps 20, vertex fitting steps 20
    "two_step.mlx": (
        "apply_coord_two_steps_smoothing",
        dict(stepsmoothnum=40, normalthr=60, stepnormalnum=20, stepfitnum=20)),
    "taubin.mlx": ("apply_coord_taubin_smoothing", {}),
}

MLS = {
    # filter scale r = 15, the other parameters MeshLab's defaults
    "mls_apss.mlx": ("compute_mls_projection_apss", dict(filterscale=15)),
    "rimls.mlx": ("compute_mls_projection_rimls", dict(filterscale=15)),
}


# the mixed example: MeshLab clean-up -> skeleton denoise -> a light MeshLab smoothing
MIXED_CLEANUP = (("meshing_remove_duplicate_vertices", {}), ("meshing_remove_unreferenced_vertices", {}))
MIXED_SMOOTHING = (("apply_coord_taubin_smoothing", dict(stepsmoothnum=4)),)


def _mesh():
    box = trimesh.creation.box().subdivide()
    return pymeshlab.Mesh(vertex_matrix=box.vertices, face_matrix=box.faces)


def _saved_filters(calls):
    """The <filter> elements pymeshlab's save_filter_script writes for ``calls`` (name, params)."""
    ms = pymeshlab.MeshSet()
    ms.add_mesh(_mesh())
    for name, params in calls:
        getattr(ms, name)(**params)
    with tempfile.TemporaryDirectory() as work:
        path = os.path.join(work, "saved.mlx")
        ms.save_filter_script(path)
        return mlx.parse(mlx.read_bytes(path), path)


def skeleton_denoise_text(params=None):
    """``skeleton_denoise.mlx``: "Skeleton Saliency Denoise" with ``params``."""
    return mlx.script_text([scripts.filter_element(SKELETON_SALIENCY_DENOISE, params or DenoiseParams())])


def mixed_example_text(params=None):
    """``mixed_example.mlx``: MeshLab clean-up, skeleton denoise with ``params``, light smoothing."""
    return mlx.script_text(_saved_filters(MIXED_CLEANUP)
                           + [scripts.filter_element(SKELETON_SALIENCY_DENOISE, params or DenoiseParams())]
                           + _saved_filters(MIXED_SMOOTHING))


def make_scripts(baselines=BASELINES, examples=HERE):
    """Write the baseline scripts into ``baselines`` and the two examples into ``examples``; returns
    the paths written."""
    written = []
    for name, (filt, params) in SMOOTHING.items():
        ms = pymeshlab.MeshSet()
        ms.add_mesh(_mesh())
        getattr(ms, filt)(**params)
        written.append(os.path.join(baselines, name))
        ms.save_filter_script(written[-1])
    for name, (filt, params) in MLS.items():
        ms = pymeshlab.MeshSet()
        ms.add_mesh(_mesh())
        ms.compute_normal_per_vertex()
        ms.add_mesh(_mesh())
        ms.clear_filter_script()
        ms.set_current_mesh(0)
        getattr(ms, filt)(controlmesh=0, proxymesh=1, **params)
        written.append(os.path.join(baselines, name))
        ms.save_filter_script(written[-1])
    for name, text in (("skeleton_denoise.mlx", skeleton_denoise_text()),
                       ("mixed_example.mlx", mixed_example_text())):
        written.append(os.path.join(examples, name))
        with open(written[-1], "w", encoding="utf-8") as f:
            f.write(text)
    return written


if __name__ == "__main__":
    for path in make_scripts():
        print(path)
