"""Mesh files in and out (any format trimesh reads/writes), validated and written atomically."""

import glob
import io
import logging
import os
import re

import numpy as np
import trimesh

from skelfilter.errors import InputError
from skelfilter.io import obj, off, ply, ply_mesh, text_rows
from skelfilter.io.formats import MESH_FORMATS, SINGLE_PRECISION_FORMATS, suffix
from skelfilter.io.input_files import check_input_file
from skelfilter.io.output_files import atomic_write, check_sidecars, write_bytes

log = logging.getLogger(__name__)


def _extension(path):
    ext = suffix(path)
    if ext not in MESH_FORMATS:
        raise InputError(f"{path}: unsupported mesh format {ext!r} (use one of {', '.join(MESH_FORMATS)})")
    return ext


def load_mesh(path):
    """Read a triangle mesh, refusing what the pipeline cannot use.

    Raises
    ------
    InputError
        Missing, unreadable or malformed file, no triangles, non-finite coordinates.
    """
    path = str(path)
    ext = _extension(path)
    check_input_file(path, "mesh")
    if os.path.getsize(path) == 0:
        raise InputError(f"{path}: the file is empty")
    text = _read(path) if ext in ("obj", "off", "ply") else None
    plain = obj.plain_text(text) if ext == "obj" else None
    if ext == "obj":
        plain = obj.split_concave(plain if plain is not None else text) or plain
    dropped = []
    try:
        if ext == "off":
            mesh, dropped = off.load_off(text)
        elif ext == "ply":
            mesh, dropped = ply_mesh.load_ply(path, text)
        elif plain is not None:  # read from memory, its materials from its folder
            mesh = trimesh.load(io.BytesIO(plain), file_type=ext, force="mesh", process=False,
                                resolver=trimesh.resolvers.FilePathResolver(os.path.dirname(os.path.abspath(path))))
        elif _utf8(path):
            mesh = trimesh.load(path, file_type=ext, force="mesh", process=False)
        else:  # trimesh hashes the name as UTF-8: such a file is read from an open file, its folder beside
            with open(path, "rb") as f:
                mesh = trimesh.load(f, file_type=ext, force="mesh", process=False,
                                    resolver=trimesh.resolvers.FilePathResolver(os.path.dirname(path)))
    except Exception as exc:  # trimesh raises many kinds on corrupt files
        raise InputError(f"{path}: malformed {ext.upper()} file ({str(exc) or type(exc).__name__})") from None
    problem = _malformed(path, ext, mesh)
    if problem:
        raise InputError(f"{path}: malformed {ext.upper()} file ({problem})")
    if ext == "obj":
        for line in obj.sidecar_problems(path, text):
            log.warning("%s: %s", path, line)
    if dropped:
        log.warning("%s: its %s are not read", path, " and ".join(dropped))
    return validate_mesh(mesh, path)


def _read(path):
    with open(path, "rb") as f:
        return f.read()


def _utf8(path):
    """Whether ``path`` is text UTF-8 can encode (a name that is none is kept by Python as surrogates)."""
    try:
        path.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _malformed(path, ext, mesh):
    """What is wrong with a file that loaded into ``mesh`` (None when nothing is seen): its header
    promises what the file does not hold, or it holds no triangles at all."""
    with open(path, "rb") as f:
        head = f.read(1 << 16)
    size = os.path.getsize(path)
    faces = len(getattr(mesh, "faces", ()))
    vertices = len(getattr(mesh, "vertices", ()))
    if ext == "stl" and not head[:5].lower() == b"solid" and size >= 84:
        promised = int(np.frombuffer(head[80:84], dtype="<u4")[0])
        if size != 84 + 50 * promised:
            return (f"binary STL: the header promises {promised} triangles, {84 + 50 * promised} bytes, "
                    f"the file has {size} bytes")
    if ext == "ply":
        if not head.startswith(b"ply"):
            return "no 'ply' line at the start"
        declared = dict(re.findall(rb"^element\s+(\w+)\s+(\d+)", head.split(b"end_header")[0], re.M))
        want_v, want_f = int(declared.get(b"vertex", -1)), int(declared.get(b"face", -1))
        # Polygons come back as several triangles, so only fewer faces betray a short file.
        if want_v >= 0 and want_f >= 0 and (vertices < want_v or faces < want_f):
            return f"the header declares {want_v} vertices and {want_f} faces; {vertices} and {faces} could be read"
    if faces == 0:
        return "no triangles could be read from it"
    return None


def validate_mesh(mesh, name="mesh"):
    """Check a mesh has triangles, finite vertices and faces that index them; returns it, as a
    ``trimesh.Trimesh`` when given plain arrays (a ``(vertices, faces)`` pair).

    Raises
    ------
    InputError
    """
    if isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        mesh = _from_arrays(*mesh, name)
    if not isinstance(mesh, trimesh.Trimesh):
        raise InputError(f"{name}: expected a trimesh.Trimesh or a (vertices, faces) pair, got "
                         f"{type(mesh).__name__}")
    if np.ndim(mesh.vertices) != 2 or np.shape(mesh.vertices)[1] != 3:
        raise InputError(f"{name}: vertices of shape (n, 3) expected, got {np.shape(mesh.vertices)}")
    if len(mesh.faces) == 0 or len(mesh.vertices) == 0:
        raise InputError(f"{name}: the mesh is empty (no triangles)")
    if not np.isfinite(mesh.vertices).all():
        raise InputError(f"{name}: vertex coordinates contain NaN or infinity")
    faces = np.asarray(mesh.faces)
    if faces.min() < 0 or faces.max() >= len(mesh.vertices):
        bad = faces.min() if faces.min() < 0 else faces.max()
        raise InputError(f"{name}: a face refers to vertex {bad}, and the mesh has {len(mesh.vertices)} "
                         f"(vertices are numbered from 0 to {len(mesh.vertices) - 1})")
    if np.ptp(mesh.vertices, axis=0).max() <= 0:
        raise InputError(f"{name}: all vertices coincide")
    return mesh


def _from_arrays(vertices, faces, name):
    """A Trimesh of plain arrays: (n, 3) numbers and (m, 3) integers (whole numbers of any type;
    trimesh would cut 0.7 down to 0)."""
    try:
        vertices = np.asarray(vertices, dtype=np.float64)
        faces = np.asarray(faces)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: the vertices and faces must be arrays of numbers ({exc})") from None
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise InputError(f"{name}: vertices of shape (n, 3) and faces of shape (m, 3) expected, got "
                         f"{vertices.shape} and {faces.shape}")
    if faces.dtype == bool or not np.issubdtype(faces.dtype, np.number):
        raise InputError(f"{name}: face indices must be integers, got {faces.dtype}")
    if not np.issubdtype(faces.dtype, np.integer):
        whole = np.isfinite(faces) & (faces == np.round(faces))
        if not whole.all():
            raise InputError(f"{name}: face indices must be whole numbers, got {faces[~whole][0].item()!r}")
    return trimesh.Trimesh(vertices, faces.astype(np.int64), process=False)


# Formats that store coordinates as float32, and the error (in parts of the mesh's size) they may add.
FLOAT32_ERROR = 1e-4


def check_mesh_output(mesh, path):
    """Refuse, before anything is computed, to write ``mesh`` (or its denoised self) to ``path``:
    in a float32 format when float32 coordinates would change its shape (a small mesh far from
    the origin: single precision keeps 7 digits), or as a textured OBJ whose material library or
    texture name is taken by a file that is not part of an earlier ``path``.

    Raises
    ------
    InputError, OutputError
    """
    ext = os.path.splitext(str(path))[1].lower().lstrip(".")
    if ext == "obj" and getattr(mesh.visual, "material", None) is not None:
        stem = os.path.splitext(os.path.abspath(str(path)))[0]
        check_sidecars(str(path), [f"{stem}.mtl", *glob.glob(glob.escape(stem) + "_0.*")])
    if ext == "ply" and _texture_png(mesh) is not None:
        check_sidecars(str(path), [ply_mesh.texture_path(path)])
    if ext not in SINGLE_PRECISION_FORMATS or len(mesh.vertices) == 0:
        return
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    size = float(np.ptp(vertices, axis=0).max())
    error = float(np.abs(vertices.astype(np.float32) - vertices).max())
    if not error <= FLOAT32_ERROR * size:
        raise InputError(f"{path}: {ext.upper()} stores coordinates in single precision, which cannot hold "
                         f"this mesh (size {size:.3g} at {np.abs(vertices).max():.3g} from the origin); "
                         "use ply, obj or off")


def save_mesh(mesh, path, protect=()):
    """Write ``mesh`` to ``path`` (format from the extension), atomically.

    PLY files get double-precision vertices, as MeshLab writes them, so no digit of the coordinates
    is lost (trimesh's PLY writer rounds them to float32), and the mesh's per-vertex or per-face
    colours (``red``, ``green``, ``blue``, ``alpha``); a mesh read from a PLY file with its vertices
    (moved or not) writes that file back, every element, property and comment in its own type
    (`ply_mesh.ply_of`). OFF files keep vertex and face colours; the other formats are trimesh's (OBJ keeps
    UVs and the texture). What of the mesh the output cannot hold is named in one warning line.
    """
    ext = _extension(path)
    check_mesh_output(mesh, path)
    source = mesh.metadata.get("ply")
    source = source if isinstance(source, ply.PlyFile) else None
    if ext == "ply":
        out, sidecars = ply_mesh.ply_of(mesh, source), {}
        image = _texture_png(mesh) if not ply_mesh.same_vertices(mesh, source) else None
        if image is not None:  # the texture beside the file, as the OBJ's
            sidecars[ply_mesh.texture_path(path)] = image
            out.header_lines.append(f"comment TextureFile {os.path.basename(ply_mesh.texture_path(path))}")
        write_bytes(path, ply.ply_bytes(out), protect, sidecars)
    elif ext == "obj":
        obj.save_obj(mesh, path, protect)
    elif ext == "off":
        write_bytes(path, off.off_text(mesh, text_rows.decimal_places(mesh.vertices)).encode("ascii"), protect)
    else:
        atomic_write(path, lambda tmp: mesh.export(tmp, file_type=ext), protect)
    lost = _not_kept(mesh, source, ext)
    if lost:
        log.warning("%s: not written: %s", path, lost)


# What each output format holds of a mesh's visual (trimesh's kinds), besides the geometry.
_VISUALS_HELD = {"ply": ("vertex", "face", "texture"), "obj": ("vertex", "texture"), "off": ("vertex", "face"),
                 "glb": ("vertex", "face", "texture"), "stl": ()}


def _not_kept(mesh, source, ext):
    """What of ``mesh`` (and of the PLY file it was read from, ``source``) a file of format ``ext``
    does not hold, in words; empty when nothing."""
    if ext == "ply" and ply_mesh.same_vertices(mesh, source) and ply_mesh.same_faces(mesh, source):
        return ""  # the file it was read from, written back whole
    kind = getattr(mesh.visual, "kind", None)
    lost = []
    if kind is not None and kind not in _VISUALS_HELD[ext]:
        lost.append({"vertex": "vertex colours", "face": "face colours", "texture": "texture coordinates"}[kind])
    if source is None:
        return ", ".join(lost)
    # The properties of the visual are kept, or named above.
    held = {"vertex": set("xyz"), "face": {"vertex_indices", "vertex_index"}, "tristrips": {"vertex_indices"}}
    if kind in ("vertex", "face"):
        held[kind] |= {prefix + name for prefix in ("", "diffuse_") for name in ply.COLOUR_NAMES}
    if kind == "texture":
        held["vertex"] |= {name for names in ply.UV_NAMES for name in names}
    if ext == "ply" and ply_mesh.same_vertices(mesh, source):
        held["vertex"] = {p.name for p in source.element("vertex").properties}
    for element in source.elements:
        names = [p.name for p in element.properties if p.name not in held.get(element.name, ())]
        if names:
            lost.append(f"the input's {element.name} properties {', '.join(names)}")
    reason = ("the mesh is new" if ext == "ply" and not ply_mesh.same_vertices(mesh, source)
              else f"{ext.upper()} cannot hold them" if ext != "ply" else "the faces are new")
    return f"{'; '.join(lost)} ({reason})" if lost else ""


def _texture_png(mesh):
    """The PNG bytes of ``mesh``'s texture image, or None without one."""
    image = getattr(getattr(mesh.visual, "material", None), "image", None)
    if getattr(mesh.visual, "kind", None) != "texture" or image is None:
        return None
    buffer = io.BytesIO()
    image.save(buffer, format="PNG")
    return buffer.getvalue()


def save_parts(meshes, path, protect=()):
    """Write named meshes as one file of named parts (OBJ objects, GLB nodes), atomically.

    Parameters
    ----------
    meshes : dict
        Name -> ``trimesh.Trimesh``.
    path : str
        An .obj or .glb file.
    """
    ext = _extension(path)
    if ext not in ("obj", "glb"):
        raise InputError(f"{path}: named parts need an .obj or a .glb file")
    for mesh in meshes.values():
        check_mesh_output(mesh, path)
    scene = trimesh.Scene()
    for name, mesh in meshes.items():
        scene.add_geometry(mesh, geom_name=name, node_name=name)
    atomic_write(path, lambda tmp: scene.export(tmp, file_type=ext), protect)
