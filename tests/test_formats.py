"""What a mesh file holds comes through: polygons of any shape and size triangulated inside themselves,
Stanford tristrips, colours, texture coordinates, other PLY properties and comments, units; what an
output format cannot hold is named in one line."""

import numpy as np
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


def prism(outline, height=1.0):
    """A prism over a counter-clockwise outline (k, 2): its vertices and its faces, two k-gon caps and k quads."""
    k = len(outline)
    vertices = np.concatenate([np.column_stack([outline, np.zeros(k)]), np.column_stack([outline, np.full(k, height)])])
    faces = [list(range(k))[::-1], list(range(k, 2 * k))] + [[i, (i + 1) % k, (i + 1) % k + k, i + k] for i in range(k)]
    return vertices, faces


PENTAGON = np.column_stack([np.cos(np.arange(5) * 2 * np.pi / 5), np.sin(np.arange(5) * 2 * np.pi / 5)])
L_SHAPE = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], dtype=float)  # area 3, concave at (1, 1)


def off_file(path, vertices, faces, vertex_colours=None, keyword="OFF"):
    rows = [" ".join(f"{x:.9g}" for x in v) + ("" if vertex_colours is None else " " + " ".join(map(str, c)))
            for v, c in zip(vertices, vertex_colours if vertex_colours is not None else vertices)]
    rows += [f"{len(f)} " + " ".join(map(str, f)) for f in faces]
    path.write_text(f"{keyword}\n{len(vertices)} {len(faces)} 0\n" + "\n".join(rows) + "\n")
    return path


def obj_file(path, vertices, faces):
    path.write_text("".join(f"v {x:.9g} {y:.9g} {z:.9g}\n" for x, y, z in vertices)
                    + "".join("f " + " ".join(str(i + 1) for i in f) + "\n" for f in faces))
    return path


def test_an_off_of_pentagons_and_quads_is_read(tmp_path):
    mesh = mesh_files.load_mesh(off_file(tmp_path / "prism.off", *prism(PENTAGON)))
    pentagon_area = 2.5 * np.sin(2 * np.pi / 5)
    assert mesh.faces.shape == (2 * 3 + 5 * 2, 3) and mesh.is_watertight
    assert np.isclose(mesh.volume, pentagon_area) and np.isclose(mesh.area, 2 * pentagon_area + 5 * np.linalg.norm(
        PENTAGON[1] - PENTAGON[0]))


def test_concave_polygons_are_triangulated_inside_themselves(tmp_path):
    """An L-prism's hexagon caps cut as a fan from their first corner cross the notch: 14 % more area."""
    vertices, faces = prism(L_SHAPE)
    area, volume = 2 * 3 + 8, 3.0  # the caps, the sides (perimeter 8, height 1)
    for path in (obj_file(tmp_path / "l.obj", vertices, faces), off_file(tmp_path / "l.off", vertices, faces)):
        mesh = mesh_files.load_mesh(path)
        assert np.isclose(mesh.area, area) and np.isclose(mesh.volume, volume) and mesh.is_watertight, path
    dart = np.array([[0, 0, 0], [2, 1, 0], [0, 2, 0], [0.5, 1, 0]])  # its notch at (0.5, 1)
    for first in range(4):
        order = np.roll(np.arange(4), -first)
        mesh = mesh_files.load_mesh(off_file(tmp_path / "dart.off", dart, [order]))
        assert np.isclose(mesh.area, 1.5), first


def test_a_coff_keeps_its_vertex_colours(tmp_path):
    sphere = trimesh.creation.icosphere(3)
    colours = np.random.default_rng(0).integers(0, 256, (len(sphere.vertices), 4))
    off_file(tmp_path / "in.off", sphere.vertices, sphere.faces, colours, keyword="COFF")
    assert np.array_equal(mesh_files.load_mesh(tmp_path / "in.off").visual.vertex_colors, colours)
    for name in ("out.off", "out.ply", "out.obj"):
        denoise_file(tmp_path / "in.off", tmp_path / name, DenoiseParams())
        kept = slice(None) if name != "out.obj" else slice(3)  # OBJ colours have no alpha
        back = mesh_files.load_mesh(tmp_path / name).visual.vertex_colors
        assert np.array_equal(back[:, kept], colours[:, kept]), name
