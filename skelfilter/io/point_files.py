"""Point cloud files in and out: PLY without faces, PCD and PTS through open3d (every per-point
attribute kept), XYZ and XYZN read here.

open3d's text reader corrupted its memory on a file without a final newline and aborted the process,
so the plain text formats are read with NumPy; a PCD file is checked whole first (open3d read a
truncated one with uninitialised points).
"""

import re
import warnings

import numpy as np

from skelfilter.errors import InputError
from skelfilter.io.formats import TEXT_POINT_COLUMNS, suffix
from skelfilter.io.input_files import check_input_file
from skelfilter.io.output_files import atomic_write
from skelfilter.runtime import native_output
from skelfilter.runtime.extras import need

MIN_POINTS = 1000


def load_points(path):
    """The cloud as an ``open3d.t.geometry.PointCloud`` (positions and every attribute, as stored).

    Raises
    ------
    InputError
        Unreadable, fewer than `MIN_POINTS` points, non-finite coordinates.
    """
    o3d = need("open3d", "point clouds")  # loaded where used: it needs the system's libusb

    path = str(path)
    check_input_file(path, "point cloud")
    ext = suffix(path)
    if ext in TEXT_POINT_COLUMNS:
        cloud = _read_text_cloud(path, TEXT_POINT_COLUMNS[ext])
    else:
        if ext == "pcd":
            _check_pcd_whole(path)
        elif ext == "pts":
            _check_pts_whole(path)
        with native_output.captured() as said:
            cloud = o3d.t.io.read_point_cloud(path)
            complaint = " | ".join(said())[:300]
        if "positions" not in cloud.point or "fail" in complaint.lower():
            raise InputError(f"{path}: malformed point cloud ({complaint or 'no points could be read'})")
    points = cloud.point.positions.numpy()
    if len(points) < MIN_POINTS:
        raise InputError(f"{path}: {len(points)} points is too sparse to make a solid of "
                         f"(at least {MIN_POINTS} needed)")
    if not np.isfinite(points).all():
        raise InputError(f"{path}: point coordinates contain NaN or infinity (or numbers too large for the "
                         "reader: over 3.4e38 where it reads single precision)")
    return cloud


def _read_text_cloud(path, columns):
    """An XYZ (``columns`` 3) or XYZN (6: positions, then normals) file as open3d's reader gives it:
    single-precision positions (and normals); further columns are ignored."""
    o3d = need("open3d", "point clouds")

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an empty file: refused below as too sparse
            values = np.loadtxt(path, dtype=np.float64, usecols=range(columns), ndmin=2, comments="#",
                                encoding="latin-1")  # numbers are ASCII; a comment may be in any encoding
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: malformed point cloud (each line must hold {columns} numbers: "
                         f"{str(exc).splitlines()[0][:200]})") from None
    with np.errstate(over="ignore"):  # beyond single precision: refused as infinite by `load_points`
        single = values[:, :columns].astype(np.float32)
    cloud = o3d.t.geometry.PointCloud(o3d.core.Tensor(single[:, :3]))
    if columns == 6:
        cloud.point.normals = o3d.core.Tensor(single[:, 3:6])
    return cloud


def _check_pcd_whole(path):
    """Refuse a PCD file that holds fewer points than its header declares (a truncated file).

    The header (text lines up to ``DATA``) gives the points (``POINTS``, else ``WIDTH`` x ``HEIGHT``)
    and the bytes of one (``SIZE`` x ``COUNT`` per field); ``ascii`` data holds a line per point,
    ``binary`` the points' bytes, ``binary_compressed`` two sizes and the compressed bytes.
    """
    with open(path, "rb") as f:
        data = f.read()
    header, fields, at = {}, None, 0
    while at < len(data):
        end = data.find(b"\n", at)
        end = len(data) if end < 0 else end
        words = data[at:end].decode("ascii", "replace").split()
        at = end + 1
        if words and not words[0].startswith("#"):
            header[words[0].upper()] = words[1:]
            if words[0].upper() == "DATA":
                fields = words[1:2]
                break
    try:
        sizes = [int(v) for v in header["SIZE"]]
        counts = [int(v) for v in header.get("COUNT", ["1"] * len(sizes))]
        points = int(header["POINTS"][0]) if "POINTS" in header else \
            int(header["WIDTH"][0]) * int(header["HEIGHT"][0])
    except (KeyError, IndexError, ValueError):
        raise InputError(f"{path}: malformed point cloud (the PCD header lacks SIZE, POINTS or WIDTH and "
                         "HEIGHT)") from None
    kind, body = (fields or ["?"])[0].lower(), len(data) - at
    if kind == "ascii":
        held = len([line for line in data[at:].splitlines() if line.strip()])
    elif kind == "binary":
        held = body // max(sum(s * c for s, c in zip(sizes, counts)), 1)
    elif kind == "binary_compressed":
        compressed = int.from_bytes(data[at:at + 4], "little") if body >= 8 else None
        held = points if compressed is not None and body >= 8 + compressed else 0
    else:
        raise InputError(f"{path}: malformed point cloud (PCD data {kind!r}: ascii, binary or binary_compressed "
                         "expected)")
    if held < points:
        raise InputError(f"{path}: the point cloud is truncated (its header declares {points} points, the file "
                         f"holds {held})")


def _check_pts_whole(path):
    """Refuse a PTS file holding fewer point lines than its first line declares (open3d would make
    up the missing points at the origin, and allocate for them all first)."""
    with open(path, "rb") as f:
        first, body = f.readline(), f.read()
    try:
        declared = int(first.split()[0])
    except (IndexError, ValueError):
        raise InputError(f"{path}: malformed point cloud (a PTS file starts with its number of points, got "
                         f"{first[:40].decode('latin-1').strip()!r})") from None
    held = len(re.findall(rb"^[ \t]*[-+.0-9]", body, re.M))
    if held < declared:
        raise InputError(f"{path}: the point cloud is truncated (its first line declares {declared} points, the "
                         f"file holds {held})")


def save_points(cloud, path, protect=()):
    """Write a cloud (its format from the suffix), atomically."""
    o3d = need("open3d", "point clouds")

    def write(tmp):
        if not o3d.t.io.write_point_cloud(tmp, cloud):
            raise InputError(f"{path}: open3d could not write the point cloud")

    atomic_write(str(path), write, protect)
