"""Mesh files in and out (any format trimesh reads/writes), validated and written atomically."""

import glob
import io
import logging
import os
import re

import numpy as np
import trimesh

from skelfilter.errors import InputError
from skelfilter.io import off, ply, polygons, text_rows
from skelfilter.io.formats import MESH_FORMATS, SINGLE_PRECISION_FORMATS, suffix
from skelfilter.io.input_files import check_input_file
from skelfilter.io.output_files import atomic_write, check_sidecars

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
    plain = _plain_obj(text) if ext == "obj" else None
    if ext == "obj":
        plain = _split_concave_obj(plain if plain is not None else text) or plain
    dropped = []
    try:
        if ext == "off":
            mesh, dropped = off.load_off(text)
        elif ext == "ply":
            mesh, dropped = _load_ply(path, text)
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
        for line in _obj_sidecar_problems(path, text):
            log.warning("%s: %s", path, line)
    if dropped:
        log.warning("%s: its %s are not read", path, " and ".join(dropped))
    return validate_mesh(mesh, path)


def _read(path):
    with open(path, "rb") as f:
        return f.read()


def _plain_obj(text):
    """An OBJ file's ``text`` with tabs as spaces and comments at line ends (``v 0 0 0 # corner``)
    removed, which trimesh's reader does not take; None where it has neither."""
    if b"\t" not in text and not re.search(rb"[^\s#][ \t]*#", text):
        return None
    return re.sub(rb"[ \t]+#[^\r\n]*", b"", text.replace(b"\t", b" "))


_OBJ_POLYGON = re.compile(rb"^[ \t]*f((?:[ \t]+\S+){4,})[ \t]*\r?$", re.M)
_OBJ_VERTEX = re.compile(rb"^[ \t]*v[ \t]+([^\n]*)", re.M)


def _split_concave_obj(text):
    """An OBJ file's ``text`` with its concave polygons written as triangles cut inside them
    (`polygons.triangulate`), their texture and normal indices kept: trimesh cuts every polygon as a fan
    from its first corner, across a concave one's notch. None where it has no concave polygon (or
    is malformed: trimesh says how)."""
    found = list(_OBJ_POLYGON.finditer(text))
    if not found:
        return None
    try:
        values, widths = text_rows.numbers(_OBJ_VERTEX.findall(text))
    except ValueError:
        return None
    if (widths < 3).any():
        return None
    vertices = values[(np.cumsum(widths) - widths)[:, None] + np.arange(3)]
    bodies = b"\n".join(match.group(1) for match in found)
    counts = text_rows.words_per_line(bodies, len(found))
    words = np.array(bodies.split(), dtype=object)
    indices = np.array(re.findall(rb"(?<!\S)(-?\d+)", bodies), dtype=np.int64)
    if len(indices) != len(words):
        return None
    if (indices < 0).any():  # relative to the vertices defined before the face
        defined = np.searchsorted([m.start() for m in _OBJ_VERTEX.finditer(text)],
                                  [m.start() for m in found]).repeat(counts)
        indices = np.where(indices < 0, defined + indices + 1, indices)
    indices -= 1
    if indices.min() < 0 or indices.max() >= len(vertices):
        return None
    concave = np.flatnonzero(polygons.is_concave(vertices, counts, indices))
    if not len(concave):
        return None
    starts = np.cumsum(counts) - counts
    taken = polygons.spans(starts[concave], counts[concave])
    triangles, _ = polygons.triangulate(vertices[indices], counts[concave], taken)
    lines = (b"f %s %s %s\n" * len(triangles)) % tuple(words[triangles].ravel())
    cuts = np.concatenate([[0], np.flatnonzero(np.frombuffer(lines, np.uint8) == ord("\n")) + 1])
    sizes = counts[concave] - 2
    first = np.cumsum(sizes) - sizes
    pieces, last = [], 0
    for k, polygon_at in enumerate(concave):  # the concave polygons only, where the text changes
        match = found[polygon_at]
        pieces += [text[last:match.start()], lines[cuts[first[k]]:cuts[first[k] + sizes[k]] - 1]]
        last = match.end()
    return b"".join(pieces + [text[last:]])


def _obj_sidecar_problems(path, text):
    """What of an OBJ file's materials is not read, in words: a material library (``mtllib``) or a
    texture (``map_Kd``) that is missing, lies outside the OBJ's folder, or has a name that is not
    UTF-8. trimesh reads the mesh without them and says so only in a debug log."""
    folder = os.path.realpath(os.path.dirname(os.path.abspath(path)))
    problems = []
    for library in re.findall(rb"^[ \t]*mtllib[ \t]+(.+?)[ \t]*\r?$", text, re.M):
        target, problem = _sidecar(folder, library)
        if problem:
            problems.append(f"its material library {problem}; the mesh is read without its materials")
            continue
        with open(target, "rb") as f:
            material = f.read()
        for texture in re.findall(rb"^[ \t]*map_Kd[ \t]+(?:-\S+[ \t]+\S+[ \t]+)*(.+?)[ \t]*\r?$", material, re.M):
            _, problem = _sidecar(os.path.dirname(target), texture)
            if problem:
                problems.append(f"its texture {problem}; the mesh is read without it")
    return problems


def _sidecar(folder, name):
    """The file an OBJ or MTL file names, and what keeps it from being read (None when nothing)."""
    try:
        text = name.decode("utf-8")
    except UnicodeDecodeError:
        return None, f"{name.decode('latin-1')!r} has a name that is not UTF-8"
    target = os.path.realpath(os.path.join(folder, text))
    if os.path.commonpath([folder, target]) != folder:
        return None, f"{text!r} lies outside the file's folder (not read)"
    if not os.path.isfile(target):
        return None, f"{text!r} is missing"
    return target, None


def _utf8(path):
    """Whether ``path`` is text UTF-8 can encode (a name that is none is kept by Python as surrogates)."""
    try:
        path.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _load_ply(path, data):
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
        check_sidecars(str(path), [_ply_texture_path(path)])
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
    (`_ply_of`). OFF files keep vertex and face colours; the other formats are trimesh's (OBJ keeps
    UVs and the texture). What of the mesh the output cannot hold is named in one warning line.
    """
    ext = _extension(path)
    check_mesh_output(mesh, path)
    source = mesh.metadata.get("ply")
    source = source if isinstance(source, ply.PlyFile) else None
    if ext == "ply":
        out, sidecars = _ply_of(mesh, source), {}
        image = _texture_png(mesh) if not _same_vertices(mesh, source) else None
        if image is not None:  # the texture beside the file, as the OBJ's
            sidecars[_ply_texture_path(path)] = image
            out.header_lines.append(f"comment TextureFile {os.path.basename(_ply_texture_path(path))}")
        _write_bytes(path, ply.ply_bytes(out), protect, sidecars)
    elif ext == "obj":
        _save_obj(mesh, path, protect)
    elif ext == "off":
        _write_bytes(path, off.off_text(mesh, _decimal_places(mesh.vertices)).encode("ascii"), protect)
    else:
        atomic_write(path, lambda tmp: mesh.export(tmp, file_type=ext), protect)
    lost = _not_kept(mesh, source, ext)
    if lost:
        log.warning("%s: not written: %s", path, lost)


# What each output format holds of a mesh's visual (trimesh's kinds), besides the geometry.
_VISUALS_HELD = {"ply": ("vertex", "face", "texture"), "obj": ("vertex", "texture"), "off": ("vertex", "face"),
                 "glb": ("vertex", "face", "texture"), "stl": ()}


def _same_vertices(mesh, source):
    return source is not None and source.element("vertex").count == len(mesh.vertices)


def _not_kept(mesh, source, ext):
    """What of ``mesh`` (and of the PLY file it was read from, ``source``) a file of format ``ext``
    does not hold, in words; empty when nothing."""
    if ext == "ply" and _same_vertices(mesh, source) and _same_faces(mesh, source):
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
    if ext == "ply" and _same_vertices(mesh, source):
        held["vertex"] = {p.name for p in source.element("vertex").properties}
    for element in source.elements:
        names = [p.name for p in element.properties if p.name not in held.get(element.name, ())]
        if names:
            lost.append(f"the input's {element.name} properties {', '.join(names)}")
    reason = ("the mesh is new" if ext == "ply" and not _same_vertices(mesh, source)
              else f"{ext.upper()} cannot hold them" if ext != "ply" else "the faces are new")
    return f"{'; '.join(lost)} ({reason})" if lost else ""


def _same_faces(mesh, source):
    """Whether ``mesh``'s triangles are those of its PLY file's faces and tristrips."""
    triangles, _ = ply.faces_of(source, ply.vertex_fields(source, "xyz"))
    return np.array_equal(np.asarray(mesh.faces), triangles)


def _ply_of(mesh, source):
    """The PLY file to write for ``mesh``: the file it was read from (``source``) with its vertices moved,
    their normals made anew where it has them, its faces kept where they are the mesh's; else the
    mesh's vertices in double precision, its triangles and colours, and the source's comments."""
    if _same_vertices(mesh, source):
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
        if _same_faces(mesh, source):
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


def _write_bytes(path, data, protect, sidecars=None):
    def write(tmp):
        with open(tmp, "wb") as f:
            f.write(data)

    atomic_write(path, write, protect, sidecars=sidecars)


def _ply_texture_path(path):
    return os.path.splitext(os.path.abspath(str(path)))[0] + "_0.png"


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


_MTL_PLACEHOLDER, _MATERIAL_PLACEHOLDER = "skelfilter-mtl-3f9c", "skelfilter_material_3f9c"


def _save_obj(mesh, path, protect):
    """OBJ with its material library and texture named after it (``out.mtl``, ``out_0.png``), written
    with it in one step: two outputs in one folder never share them, and no file of that name the
    run did not make is replaced (`output_files.check_sidecars`)."""
    from trimesh.exchange.obj import export_obj

    stem = os.path.splitext(os.path.basename(str(path)))[0]
    # trimesh drops the material of a name it cannot encode (a Latin-1 file name, any non-ASCII one
    # under LC_ALL=C) and says so only in a debug log; it gets placeholders, replaced by the real
    # names' bytes, as the file system spells them, once the text is made.
    names = {_MTL_PLACEHOLDER: stem, _MATERIAL_PLACEHOLDER: re.sub(r"\s", "_", stem)}
    if getattr(mesh.visual, "material", None) is not None:
        visual = mesh.visual.copy()
        visual.material.name = _MATERIAL_PLACEHOLDER + "_0"
        mesh = trimesh.Trimesh(mesh.vertices, mesh.faces, visual=visual, process=False)
    text, files = export_obj(mesh, return_texture=True, write_texture=False, mtl_name=f"{_MTL_PLACEHOLDER}.mtl",
                             digits=_decimal_places(mesh.vertices))
    directory = os.path.dirname(os.path.abspath(str(path)))

    def named(data):
        for placeholder, name in names.items():
            data = data.replace(placeholder.encode(), os.fsencode(name))
        return data

    sidecars = {}
    for name, data in files.items():
        for placeholder, real in names.items():
            name = name.replace(placeholder, real)
        sidecars[os.path.join(directory, name)] = named(data) if name.endswith(".mtl") else data

    def write(tmp):
        with open(tmp, "wb") as f:
            f.write(named(text.encode("utf-8")))

    atomic_write(path, write, protect, sidecars=sidecars)


def _decimal_places(points):
    """Decimal places for text formats (trimesh writes fixed-point numbers) that keep 17
    significant digits of the largest coordinate, so a mesh a micron across keeps its shape."""
    largest = float(np.abs(points).max()) if len(points) else 0.0
    return int(np.clip(17 - np.floor(np.log10(largest)), 8, 330)) if largest > 0 else 8


def _vertex_records(points, properties, dtype):
    """Structured vertex records: x, y, z of ``dtype``, then ``properties`` in their own dtypes."""
    names = ["x", "y", "z"] + list(properties)
    kinds = [dtype] * 3 + [np.asarray(v).dtype.str if np.asarray(v).dtype == np.uint8 else dtype
                           for v in properties.values()]
    data = np.empty(len(points), dtype=list(zip(names, kinds)))
    data["x"], data["y"], data["z"] = np.asarray(points).T
    for n in properties:
        data[n] = properties[n]
    return data


def _save_ply(path, vertices, faces, protect):
    """Binary little-endian PLY of a vertex record array and, if given, face records (count,
    indices, then any colour fields)."""
    kinds = {"<f4": "float", "<f8": "double", "|u1": "uchar"}
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(vertices)}"]
    header += [f"property {kinds[vertices.dtype[n].str]} {n}" for n in vertices.dtype.names]
    if faces is not None:
        header += [f"element face {len(faces)}", "property list uchar int vertex_indices"]
        header += [f"property uchar {n}" for n in faces.dtype.names[2:]]
    header.append("end_header")

    def write(tmp):
        with open(tmp, "wb") as f:
            f.write(("\n".join(header) + "\n").encode("ascii"))
            f.write(vertices.tobytes())
            if faces is not None:
                f.write(faces.tobytes())

    atomic_write(path, write, protect)


def save_point_cloud_ply(path, points, properties, protect=()):
    """Binary PLY point cloud with per-point float properties.

    ``properties`` maps names to arrays; a ``quality`` entry is what MeshLab
    colours by (Colors > Per Vertex Quality), the others load as attributes.
    """
    _save_ply(path, _vertex_records(points, properties, "<f4"), None, protect)
