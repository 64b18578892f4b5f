"""A mesh and its PLY file: the mesh made of a `ply.PlyFile` (carrying it, so that a PLY output of the
same vertices writes it back whole), the file to write for a mesh, and point clouds with per-point
properties."""

import logging
import os
import re

import numpy as np
import trimesh

from skelfilter.io import ply
from skelfilter.io.output_files import write_bytes

log = logging.getLogger(__name__)


def load_ply(path, data):
    """A mesh of a PLY file (`ply.read_ply`), carrying it (``metadata["ply"]``); its texture image from
    the file's folder (one warning line when missing), and what of it the mesh does not hold."""
    source = ply.read_ply(data)
    vertex = source.element("vertex")
    if vertex is None or ply.vertex_fields(source, "xyz") is None:
        raise ValueError("no vertex element with x, y and z")
    vertices = ply.vertex_fields(source, "xyz")
    triangles, polygon = ply.faces_of(source, vertices)
    uv = next((ply.vertex_fields(source, names) for names in ply.UV_NAMES
               if ply.vertex_fields(source, names) is not None), None)
    image = _texture_image(path, source.texture_file)
    face_colours = ply.colours(source.element("face"))
    vertex_colours = ply.colours(vertex)
    if vertex_colours is None:
        vertex_colours = ply.colours(vertex, "diffuse_")
    if uv is not None:  # a PLY output writes the colours from the file it carries
        visual = trimesh.visual.TextureVisuals(uv=uv, image=image)
    elif vertex_colours is not None:
        visual = trimesh.visual.ColorVisuals(vertex_colors=vertex_colours)
    elif face_colours is not None:
        white = np.full((1, 4), 255, np.uint8)  # a tristrip's triangles have no face of their own
        visual = trimesh.visual.ColorVisuals(face_colors=np.concatenate([face_colours, white])[polygon])
    else:
        visual = None
    face = source.element("face")
    if face is not None and "texcoord" in face.data:
        log.warning("%s: its per-wedge texture coordinates are not kept (the mesh is read without them)", path)
    mesh = trimesh.Trimesh(vertices, triangles, visual=visual, process=False)
    mesh.metadata["ply"] = source
    return mesh, []


def _texture_image(path, name):
    """The image a PLY file's ``comment TextureFile`` names, from its folder; None without one (one
    warning line where it is missing or Pillow is not installed)."""
    if name is None:
        return None
    target = os.path.join(os.path.dirname(os.path.abspath(path)), name)
    if not os.path.isfile(target):
        log.warning("%s: its texture %s is missing; the mesh is read without it", path, name)
        return None
    try:
        from PIL import Image
    except ImportError:
        log.warning("%s: its texture %s is not read (Pillow is not installed)", path, name)
        return None
    with Image.open(target) as image:
        image.load()
        return image.copy()


def same_vertices(mesh, source):
    return source is not None and source.element("vertex").count == len(mesh.vertices)


def same_faces(mesh, source):
    """Whether ``mesh``'s triangles are those of its PLY file's faces and tristrips."""
    triangles, _ = ply.faces_of(source, ply.vertex_fields(source, "xyz"))
    return np.array_equal(np.asarray(mesh.faces), triangles)


def ply_of(mesh, source):
    """The PLY file to write for ``mesh``: the file it was read from (``source``) with its vertices moved,
    their normals made anew where it has them, its faces kept where they are the mesh's; else the
    mesh's vertices in double precision, its triangles and colours, and the source's comments."""
    if same_vertices(mesh, source):
        out = ply.PlyFile(source.format, list(source.header_lines),
                          [ply.Element(e.name, e.count, list(e.properties), dict(e.data)) for e in source.elements])
        vertex = out.element("vertex")
        types = {p.name: p.type for p in vertex.properties}
        vertices = np.asarray(mesh.vertices, dtype=np.float64)
        for axis, name in enumerate("xyz"):
            vertex.data[name] = vertices[:, axis].astype(types[name])
        if all(n in types for n in ("nx", "ny", "nz")) and not np.array_equal(vertices, ply.vertex_fields(source,
                                                                                                          "xyz")):
            for axis, name in enumerate(("nx", "ny", "nz")):
                vertex.data[name] = mesh.vertex_normals[:, axis].astype(types[name])
        if same_faces(mesh, source):
            return out
        out.elements = [e for e in out.elements if e.name not in ("face", "tristrips")]
    else:
        notes = [] if source is None else [n for n in source.header_lines if not re.match(r"comment\s+texturefile",
                                                                                           n, re.I)]
        out = ply.PlyFile("binary_little_endian", notes, [])
        vertex = ply.Element("vertex", len(mesh.vertices), [ply.Property(n, "f8") for n in "xyz"])
        vertex.data = dict(zip("xyz", np.asarray(mesh.vertices, dtype=np.float64).T))
        if getattr(mesh.visual, "kind", None) == "vertex":
            _add_colours(vertex, mesh.visual.vertex_colors)
        uv = getattr(mesh.visual, "uv", None) if getattr(mesh.visual, "kind", None) == "texture" else None
        if uv is not None:  # as MeshLab names them
            vertex.properties += [ply.Property(name, "f4") for name in ("texture_u", "texture_v")]
            vertex.data.update(texture_u=np.asarray(uv)[:, 0], texture_v=np.asarray(uv)[:, 1])
        out.elements.append(vertex)
    face = ply.Element("face", len(mesh.faces), [ply.Property("vertex_indices", "i4", "u1")])
    face.data["vertex_indices"] = (np.full(len(mesh.faces), 3), np.asarray(mesh.faces).reshape(-1))
    if getattr(mesh.visual, "kind", None) == "face":
        _add_colours(face, mesh.visual.face_colors)
    out.elements.insert(out.elements.index(vertex) + 1, face)
    return out


def _add_colours(element, colours):
    colours = np.asarray(colours, dtype=np.uint8)
    element.properties += [ply.Property(name, "u1") for name in ply.COLOUR_NAMES]
    element.data.update({name: colours[:, i] for i, name in enumerate(ply.COLOUR_NAMES)})


def texture_path(path):
    return os.path.splitext(os.path.abspath(str(path)))[0] + "_0.png"


def save_point_cloud_ply(path, points, properties, protect=()):
    """Binary PLY point cloud, atomically: float32 x, y, z and per-point properties (uint8 arrays stay
    uint8, the others float32).

    ``properties`` maps names to arrays; a ``quality`` entry is what MeshLab
    colours by (Colors > Per Vertex Quality), the others load as attributes.
    """
    points = np.asarray(points)
    columns = {**dict(zip("xyz", points.T)), **{name: np.asarray(v) for name, v in properties.items()}}
    vertex = ply.Element("vertex", len(points), [ply.Property(name, "u1" if v.dtype == np.uint8 else "f4")
                                                 for name, v in columns.items()], columns)
    write_bytes(path, ply.ply_bytes(ply.PlyFile("binary_little_endian", [], [vertex])), protect)
