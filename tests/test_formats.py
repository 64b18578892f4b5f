"""What a mesh file holds comes through: polygons of any shape and size triangulated inside themselves,
Stanford tristrips, colours, texture coordinates, other PLY properties and comments, units; what an
output format cannot hold is named in one line."""

import trimesh

from skelfilter.io import mesh_files
from skelfilter.jobs.denoise_file import denoise_file
from skelfilter.params import DenoiseParams

CLOSE = DenoiseParams(output_mesh="closed", resolution=32)


def test_close_keeps_the_units(tmp_path):
    """A new closed mesh is of the input's length unit, which a GLB states."""
    sphere = trimesh.creation.icosphere(3)
    sphere.units = "mm"
    sphere.export(tmp_path / "in.glb")
    denoise_file(tmp_path / "in.glb", tmp_path / "out.glb", CLOSE)
    assert mesh_files.load_mesh(tmp_path / "out.glb").units == "mm"
