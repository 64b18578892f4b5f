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
    text = sphere.export(file_type="ply", encoding="ascii").decode()
    (tmp_path / "in.ply").write_text(text.replace("format ascii 1.0\n", "format ascii 1.0\ncomment units mm\n"))
    denoise_file(tmp_path / "in.ply", tmp_path / "out.ply", CLOSE)
    assert b"\ncomment units mm\n" in (tmp_path / "out.ply").read_bytes().split(b"end_header")[0]


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


def ply_text(vertices, faces, vertex_columns=(), face_columns=(), comments=(), vertex_type="float"):
    """An ASCII PLY file: ``vertex_columns`` / ``face_columns`` are (PLY type, name, values) after x, y, z /
    after the face's vertex indices."""
    head = ["ply", "format ascii 1.0", *comments, f"element vertex {len(vertices)}"]
    head += [f"property {vertex_type} {n}" for n in "xyz"] + [f"property {t} {n}" for t, n, _ in vertex_columns]
    head += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
    head += [f"property {t} {n}" for t, n, _ in face_columns] + ["end_header"]
    rows = [" ".join([f"{x:.9g}" for x in v] + [f"{c[2][i]:.9g}" for c in vertex_columns])
            for i, v in enumerate(vertices)]
    rows += [" ".join([str(len(f)), *map(str, f)] + [f"{c[2][i]:.9g}" for c in face_columns])
             for i, f in enumerate(faces)]
    return "\n".join(head + rows) + "\n"


def test_a_ply_of_quads_and_triangles_with_face_colours_is_read(tmp_path):
    """trimesh read it as 'shapes (8, 12) and (6, 4) are not aligned' (ASCII) or refused it (binary)."""
    box = trimesh.creation.box(extents=(1, 1, 1))
    quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4]]  # the box's sides but x = +0.5
    faces = quads + [[1, 5, 7], [1, 7, 3]]
    rgb = np.random.default_rng(0).integers(0, 256, (len(faces), 3))
    columns = [("uchar", name, rgb[:, i]) for i, name in enumerate(("red", "green", "blue"))]
    (tmp_path / "in.ply").write_text(ply_text(box.vertices, faces, face_columns=columns))
    binary = trimesh.Trimesh(box.vertices, box.faces)  # the same file in binary, through our writer
    for name in ("in.ply", "binary.ply"):
        if name == "binary.ply":
            mesh_files.save_mesh(mesh_files.load_mesh(tmp_path / "in.ply"), tmp_path / name)
        mesh = mesh_files.load_mesh(tmp_path / name)
        assert mesh.faces.shape == (12, 3) and mesh.is_watertight and np.isclose(mesh.volume, 1.0), name
        assert np.array_equal(mesh.visual.face_colors[:, :3], rgb[[0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 6]]), name
    assert binary.is_watertight
    assert "element face 7" in (tmp_path / "binary.ply").read_bytes().decode("latin-1")  # quads written back


def test_stanford_tristrips_are_read(tmp_path):
    """A box as two strips (Stanford's ``element tristrips``, -1 ending a strip): closed, outward."""
    box = trimesh.creation.box(extents=(1, 1, 1))  # vertex i at (+-0.5): x from bit 2, y from bit 1, z from bit 0
    strips = [0, 1, 2, 3, 6, 7, 4, 5, 0, 1, -1, 1, 5, 3, 7, -1, 0, 2, 4, 6, -1]
    head = ["ply", "format ascii 1.0", "element vertex 8", "property float x", "property float y", "property float z",
            "element tristrips 1", "property list int int vertex_indices", "end_header"]
    rows = [" ".join(f"{x:g}" for x in v) for v in box.vertices] + [" ".join(map(str, [len(strips), *strips]))]
    (tmp_path / "strips.ply").write_text("\n".join(head + rows) + "\n")
    mesh = mesh_files.load_mesh(tmp_path / "strips.ply")
    assert len(mesh.faces) == 12 and mesh.is_watertight and np.isclose(abs(mesh.volume), 1.0)
    assert mesh.is_winding_consistent


def test_a_ply_of_concave_polygons_is_triangulated_inside_them(tmp_path):
    vertices, faces = prism(L_SHAPE)
    (tmp_path / "l.ply").write_text(ply_text(vertices, faces))
    mesh = mesh_files.load_mesh(tmp_path / "l.ply")
    assert np.isclose(mesh.area, 14.0) and np.isclose(mesh.volume, 3.0)


def test_a_ply_comes_back_whole(tmp_path, caplog):
    """Its float32 coordinates, other vertex properties (a quality, texture coordinates), face
    properties, comments and texture reference, as they were; an output that cannot hold them names them."""
    from PIL import Image

    from skelfilter.io import ply

    sphere = trimesh.creation.icosphere(3)
    n = len(sphere.vertices)
    rng = np.random.default_rng(1)
    quality, uv = rng.random(n), rng.random((n, 2))
    Image.new("RGB", (8, 8), (200, 10, 10)).save(tmp_path / "skin.png")
    text = ply_text(sphere.vertices, sphere.faces,
                    [("float", "quality", quality), ("float", "s", uv[:, 0]), ("float", "t", uv[:, 1])],
                    [("uchar", "flags", np.arange(len(sphere.faces)) % 7)],
                    ["comment TextureFile skin.png", "comment units mm", "obj_info scanned 2024"])
    (tmp_path / "in.ply").write_text(text)
    before = ply.read_ply((tmp_path / "in.ply").read_bytes())
    assert np.allclose(mesh_files.load_mesh(tmp_path / "in.ply").visual.uv, uv, atol=1e-6)
    denoise_file(tmp_path / "in.ply", tmp_path / "out.ply", DenoiseParams())
    after = ply.read_ply((tmp_path / "out.ply").read_bytes())
    assert after.header_lines == before.header_lines
    for old, new in zip(before.elements, after.elements):
        assert [(p.name, p.type, p.count_type) for p in old.properties] == \
            [(p.name, p.type, p.count_type) for p in new.properties]
        for name, values in old.data.items():
            assert all(np.array_equal(a, b) for a, b in zip(values, new.data[name])) if isinstance(values, tuple) \
                else np.array_equal(values, new.data[name]), name
    caplog.set_level("WARNING")
    denoise_file(tmp_path / "in.ply", tmp_path / "out.stl", DenoiseParams())
    said = [r.getMessage() for r in caplog.records if "not written" in r.getMessage()]
    assert len(said) == 1 and "texture coordinates" in said[0] and "quality" in said[0] and "flags" in said[0], said


def test_a_textured_mesh_keeps_its_texture_in_a_ply_output(tmp_path):
    """PLY holds texture coordinates and names its image: an OBJ's texture is written beside it."""
    from PIL import Image

    sphere = trimesh.creation.icosphere(3)
    uv = np.random.default_rng(2).random((len(sphere.vertices), 2))
    textured = trimesh.Trimesh(sphere.vertices, sphere.faces, process=False,
                               visual=trimesh.visual.TextureVisuals(uv=uv, image=Image.new("RGB", (4, 4), (9, 8, 7))))
    textured.export(tmp_path / "in.obj")
    denoise_file(tmp_path / "in.obj", tmp_path / "out.ply", DenoiseParams())
    back = mesh_files.load_mesh(tmp_path / "out.ply")
    assert np.allclose(back.visual.uv, uv, atol=1e-6) and back.visual.material.image.getpixel((0, 0)) == (9, 8, 7)
