"""Regenerate the MeshLab baseline scripts of the comparison (thesis §8.2.1) in this folder.

Each script is written by pymeshlab's own ``MeshSet.save_filter_script`` after applying its filter to a
small mesh, so the XML is exactly what pymeshlab/MeshLab write. Run: ``python meshlab_scripts/make_scripts.py``.

The MLS projections (APSS, RIMLS) crash when a mesh is projected onto itself, so they are applied the
safe way: layer 0 with per-vertex normals is the point set, layer 1 a copy that is projected
(``controlmesh=0, proxymesh=1``). The normal computation is cleared from the recorded script, which
therefore holds only the MLS filter with ControlMesh 0 and ProxyMesh 1.
"""

import os

import pymeshlab
import trimesh

HERE = os.path.dirname(os.path.abspath(__file__))

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


def _mesh():
    box = trimesh.creation.box().subdivide()
    return pymeshlab.Mesh(vertex_matrix=box.vertices, face_matrix=box.faces)


def make_scripts(folder=HERE):
    written = []
    for name, (filt, params) in SMOOTHING.items():
        ms = pymeshlab.MeshSet()
        ms.add_mesh(_mesh())
        getattr(ms, filt)(**params)
        ms.save_filter_script(os.path.join(folder, name))
        written.append(name)
    for name, (filt, params) in MLS.items():
        ms = pymeshlab.MeshSet()
        ms.add_mesh(_mesh())
        ms.compute_normal_per_vertex()
        ms.add_mesh(_mesh())
        ms.clear_filter_script()
        ms.set_current_mesh(0)
        getattr(ms, filt)(controlmesh=0, proxymesh=1, **params)
        ms.save_filter_script(os.path.join(folder, name))
        written.append(name)
    return written


if __name__ == "__main__":
    for name in make_scripts():
        print(os.path.join(HERE, name))
