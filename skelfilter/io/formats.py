"""Every file format skelfilter reads and writes, in one table, and the kind of a file from its name.

Meshes are read and written by trimesh (:mod:`skelfilter.io.mesh_files` adds what it misses), point
clouds by open3d and the readers of :mod:`skelfilter.io.point_files`, volumes by one module per
format (:mod:`skelfilter.io.volume_formats`). A PLY file is a mesh, or a point cloud when its header
declares no faces. Every entry point (the CLI, batches, the Python functions) asks this module what a
file is, so a format added here is accepted everywhere, and a name none of them reads is refused in
one line that lists them all.
"""

import os
import re

from skelfilter.errors import InputError
from skelfilter.io.volume_formats import FORMATS as VOLUME_FORMATS

MESH_FORMATS = ("ply", "obj", "stl", "off", "glb")
# Mesh formats that store coordinates in single precision.
SINGLE_PRECISION_FORMATS = ("stl", "glb")
POINT_FORMATS = ("ply", "pcd", "xyz", "xyzn", "pts")
# The plain text point formats read by point_files: their columns (positions, then normals).
TEXT_POINT_COLUMNS = {"xyz": 3, "xyzn": 6}
KINDS = ("mesh", "points", "volume")


def suffix(path):
    """The last suffix of ``path``, lower case, without its dot (``"ply"``)."""
    return os.path.splitext(str(path))[1].lower().lstrip(".")


def volume_format(path):
    """The `VolumeFormat` of ``path`` from its suffix, or None for anything else."""
    name = str(path).lower()
    return next((fmt for fmt in VOLUME_FORMATS.values() if name.endswith(fmt.suffixes)), None)


def volume_suffixes():
    return [s for fmt in VOLUME_FORMATS.values() for s in fmt.suffixes]


def listing():
    """Every format by kind, for messages."""
    return (f"meshes: {', '.join(MESH_FORMATS)}; volumes: {', '.join(s.lstrip('.') for s in volume_suffixes())}; "
            f"point clouds: {', '.join(POINT_FORMATS)}")


def file_kind(path):
    """``volume``, ``points`` (PCD, XYZ, XYZN, PTS) or ``mesh``, from the name alone.

    Raises
    ------
    InputError
        None of these formats.
    """
    if volume_format(path) is not None:
        return "volume"
    ext = suffix(path)
    if ext in MESH_FORMATS:
        return "mesh"
    if ext in POINT_FORMATS:
        return "points"
    raise InputError(f"{path}: unsupported format {ext!r} ({listing()})")


def input_kind(path):
    """`file_kind`, a PLY file without faces being a point cloud."""
    kind = file_kind(path)
    return "points" if kind == "mesh" and is_point_cloud(path) else kind


def is_point_cloud(path):
    """True for a PCD/XYZ/XYZN/PTS file, or a PLY file whose header declares no faces (nor tristrips)."""
    ext = suffix(path)
    if ext in POINT_FORMATS and ext not in MESH_FORMATS:
        return True
    if ext != "ply" or not os.path.isfile(str(path)):
        return False
    with open(str(path), "rb") as f:
        head = f.read(1 << 16)
    if b"end_header" not in head:  # a malformed file: the mesh reader says what is wrong
        return False
    header = head.split(b"end_header")[0]
    declared = dict(re.findall(rb"^element[ \t]+(\w+)[ \t]+(\d+)", header, re.M))
    return header.startswith(b"ply") and not any(int(declared.get(name, 0)) for name in (b"face", b"tristrips"))
