"""Mesh files in and out (any format trimesh reads/writes), validated and written atomically."""

import os
import re
import tempfile

import numpy as np
import trimesh

from skelfilter.errors import InputError
from skelfilter.runtime.memory import read_field

MESH_FORMATS = ("ply", "obj", "stl", "off", "glb")


def _extension(path):
    ext = os.path.splitext(str(path))[1].lower().lstrip(".")
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
    if os.path.isdir(path):
        raise InputError(f"{path}: is a folder, not a mesh file")
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such file")
    if os.path.getsize(path) == 0:
        raise InputError(f"{path}: the file is empty")
    try:
        mesh = trimesh.load(path, file_type=ext, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many kinds on corrupt files
        raise InputError(f"{path}: malformed {ext.upper()} file ({exc})") from None
    problem = _malformed(path, ext, mesh)
    if problem:
        raise InputError(f"{path}: malformed {ext.upper()} file ({problem})")
    return validate_mesh(mesh, path)


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
        if want_v >= 0 and want_f >= 0 and (vertices != want_v or faces < want_f):
            return f"the header declares {want_v} vertices and {want_f} faces; {vertices} and {faces} could be read"
    if faces == 0:
        return "no triangles could be read from it"
    return None


def validate_mesh(mesh, name="mesh"):
    """Check a mesh has triangles and finite vertices; returns it."""
    if not isinstance(mesh, trimesh.Trimesh):
        raise InputError(f"{name}: expected a trimesh.Trimesh, got {type(mesh).__name__}")
    if len(mesh.faces) == 0 or len(mesh.vertices) == 0:
        raise InputError(f"{name}: the mesh is empty (no triangles)")
    if not np.isfinite(mesh.vertices).all():
        raise InputError(f"{name}: vertex coordinates contain NaN or infinity")
    if np.ptp(mesh.vertices, axis=0).max() <= 0:
        raise InputError(f"{name}: all vertices coincide")
    return mesh


def _same_file(a, b):
    return os.path.exists(b) and os.path.realpath(a) == os.path.realpath(b)


def check_output(path, protect=(), kinds=None):
    """Refuse an output path before anything is computed.

    ``protect`` maps what ``path`` must not be to its name in the message (``{input_path: "input"}``;
    a list means inputs); ``kinds`` lists the allowed extensions (default: any).

    Raises
    ------
    InputError
        A wrong extension, a missing folder, a folder as the path, or one of the protected files.
    """
    path = str(path)
    names = protect if isinstance(protect, dict) else {p: "input" for p in protect}
    for other, name in names.items():
        if _same_file(str(other), path) or os.path.abspath(str(other)) == os.path.abspath(path):
            raise InputError(f"{path}: refusing to overwrite the {name} file")
    if kinds is not None:
        ext = os.path.splitext(path)[1].lower().lstrip(".")
        if ext not in kinds:
            raise InputError(f"{path}: unsupported format {ext!r} (use {', '.join(kinds)})")
    if os.path.isdir(path):
        raise InputError(f"{path}: is a folder")
    if not os.path.isdir(os.path.dirname(os.path.abspath(path))):
        raise InputError(f"{path}: output folder does not exist")


def _new_file_mode(path):
    """The mode ``open`` would give ``path``: the old file's if it exists, else 0o666 less the umask
    (a temporary file is made 0o600)."""
    if os.path.exists(path):
        return os.stat(path).st_mode & 0o7777
    return 0o666 & ~_umask()


def _umask():
    """The process' umask, read without changing it where Linux shows it (os.umask sets it to read
    it, for every thread at once)."""
    value = read_field("/proc/self/status", "Umask")
    if value is not None:
        return int(value, 8)
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def file_suffix(path):
    """The file name's suffix, two of them for a compressed file (``.nii.gz``): writers that choose
    the format by the name see the output's."""
    stem, last = os.path.splitext(path)
    return os.path.splitext(stem)[1] + last if last.lower() == ".gz" else last


def atomic_write(path, write, protect=()):
    """Call ``write(tmp_path)`` then move the result onto ``path`` in one step.

    ``protect``: as in `check_output`.
    """
    path = str(path)
    check_output(path, protect)
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=directory, prefix=".skelfilter-", suffix=file_suffix(path))
    os.close(fd)
    try:
        write(tmp)
        os.chmod(tmp, _new_file_mode(path))
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


# Formats that store coordinates as float32, and the error (in parts of the mesh's size) they may add.
FLOAT32_FORMATS = ("stl", "glb")
FLOAT32_ERROR = 1e-4


def check_precision(mesh, path):
    """Refuse to write ``mesh`` in a float32 format when float32 coordinates would change its
    shape (a small mesh far from the origin: single precision keeps 7 digits).

    Raises
    ------
    InputError
    """
    ext = os.path.splitext(str(path))[1].lower().lstrip(".")
    if ext not in FLOAT32_FORMATS or len(mesh.vertices) == 0:
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
    colours (``red``, ``green``, ``blue``, ``alpha``); the other formats are trimesh's (OBJ keeps
    UVs and the texture).
    """
    ext = _extension(path)
    check_precision(mesh, path)
    if ext == "ply":
        kind = getattr(mesh.visual, "kind", None)
        vertex_colours = {} if kind != "vertex" else _colour_fields(mesh.visual.vertex_colors)
        face_colours = {} if kind != "face" else _colour_fields(mesh.visual.face_colors)
        face_fields = [("count", "u1"), ("vertex_indices", "<i4", (3,))]
        face_fields += [(name, "u1") for name in face_colours]
        faces = np.empty(len(mesh.faces), dtype=face_fields)
        faces["count"] = 3
        faces["vertex_indices"] = mesh.faces
        for name, values in face_colours.items():
            faces[name] = values
        _save_ply(path, _vertex_records(mesh.vertices, vertex_colours, "<f8"), faces, protect)
        return
    options = {"digits": _decimal_places(mesh.vertices)} if ext in ("obj", "off") else {}
    atomic_write(path, lambda tmp: mesh.export(tmp, file_type=ext, **options), protect)


def _decimal_places(points):
    """Decimal places for text formats (trimesh writes fixed-point numbers) that keep 17
    significant digits of the largest coordinate, so a mesh a micron across keeps its shape."""
    largest = float(np.abs(points).max()) if len(points) else 0.0
    return int(np.clip(17 - np.floor(np.log10(largest)), 8, 330)) if largest > 0 else 8


def _colour_fields(colours):
    colours = np.asarray(colours, dtype=np.uint8)
    return {name: colours[:, i] for i, name in enumerate(("red", "green", "blue", "alpha"))}


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
