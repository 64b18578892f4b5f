"""Point clouds in: a scanner's points made into a solid, denoised as a mesh, and the points moved back.

open3d reads the cloud (PLY without faces, PCD, PTS) with every per-point attribute; the plain text
formats XYZ and XYZN are read here (open3d's text reader corrupted its memory on a file without a
final newline and aborted the process), and a PCD file is checked whole first (open3d read a
truncated one with uninitialised points). The solid comes from screened Poisson reconstruction
(Kazhdan & Hoppe 2013) from the points' normals, estimated (principal axes of the nearest neighbours)
and oriented consistently (a minimum spanning tree over the neighbours) when the file has none. The
octree depth follows the points' spacing, so Poisson keeps what the points resolve. What it needs,
in short: a closed scan (the points all round the object, or the Poisson surface bulges over the
gaps), at least `MIN_POINTS` points, and a spacing of at most 1/`MAX_SPACING_RATIO` of the longest
side.

References
----------
.. [1] M. Kazhdan, H. Hoppe, "Screened Poisson surface reconstruction", ACM TOG 32(3), 2013.
"""

import contextlib
import os
import re
import sys
import tempfile
import warnings

import numpy as np
import trimesh

from skelfilter.errors import InputError
from skelfilter.mesh.closest_points import MeshSurface
from skelfilter.runtime.extras import load

# File suffixes read as point clouds; a PLY is one when it has no faces.
POINT_FORMATS = ("ply", "pcd", "xyz", "xyzn", "pts")
FLAT_RATIO = 1e-6  # relative spread across below which a cloud is a line or a plane
MAX_EXTENT = 1e150  # squared distances stay finite
MIN_POINTS = 1000
# The median nearest-neighbour spacing (duplicates removed) must stay under the longest side over this.
MAX_SPACING_RATIO = 60
DEPTH_RANGE = (6, 10)
# Neighbours of a point for its normal and for orienting the normals.
NEIGHBOURS = 50
# The least volume of the solid, over the cube of the longest side.
MIN_VOLUME = 1e-3
# The plain text formats read here: their columns (positions, then normals), one point per line.
TEXT_COLUMNS = {"xyz": 3, "xyzn": 6}


def is_point_cloud(path):
    """True for a PCD/XYZ/XYZN/PTS file, or a PLY file whose header declares no faces."""
    ext = os.path.splitext(str(path))[1].lower().lstrip(".")
    if ext in ("pcd", "xyz", "xyzn", "pts"):
        return True
    if ext != "ply" or not os.path.isfile(str(path)):
        return False
    with open(str(path), "rb") as f:
        head = f.read(1 << 16)
    if b"end_header" not in head:  # a malformed file: the mesh reader says what is wrong
        return False
    header = head.split(b"end_header")[0]
    return header.startswith(b"ply") and b"element face" not in header.replace(b"element face 0", b"")


def load_points(path):
    """The cloud as an ``open3d.t.geometry.PointCloud`` (positions and every attribute, as stored).

    Raises
    ------
    InputError
        Unreadable, fewer than `MIN_POINTS` points, non-finite coordinates.
    """
    o3d = load("open3d")  # loaded where used: it needs the system's libusb

    path = str(path)
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such file")
    ext = os.path.splitext(path)[1].lower().lstrip(".")
    if ext in TEXT_COLUMNS:
        cloud = _read_text_cloud(path, TEXT_COLUMNS[ext])
    else:
        if ext == "pcd":
            _check_pcd_whole(path)
        with _output_captured() as said:
            cloud = o3d.t.io.read_point_cloud(path)
            complaint = " | ".join(line.strip() for line in _plain(said()).splitlines() if line.strip())[:300]
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
    o3d = load("open3d")

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # an empty file: refused below as too sparse
            values = np.loadtxt(path, dtype=np.float64, usecols=range(columns), ndmin=2, comments="#")
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: malformed point cloud (each line must hold {columns} numbers: "
                         f"{str(exc).splitlines()[0][:200]})") from None
    cloud = o3d.t.geometry.PointCloud(o3d.core.Tensor(values[:, :3].astype(np.float32)))
    if columns == 6:
        cloud.point.normals = o3d.core.Tensor(values[:, 3:6].astype(np.float32))
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


@contextlib.contextmanager
def _output_captured():
    """What C libraries (open3d and its PLY reader) print while the block runs, on the standard output
    or error, goes to a file instead, read by the function yielded: an error stays one line."""
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:  # None: the command was started with it closed
            stream.flush()
    saved = [_duplicate(1), _duplicate(2)]
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            yield lambda: (sink.seek(0), sink.read().decode("utf-8", "replace"))[1]
        finally:
            for fd, copy in zip((1, 2), saved):
                if copy is None:  # closed before: closed again
                    os.close(fd)
                else:
                    os.dup2(copy, fd)
                    os.close(copy)


def _duplicate(fd):
    """A copy of the descriptor ``fd``, or None where it is closed."""
    try:
        return os.dup(fd)
    except OSError:
        return None


def _plain(text):
    """Text without terminal colour codes."""
    return re.sub(r"\x1b\[[0-9;]*m", "", text)


def _check_spread(points, name):
    """Refuse a cloud no solid can be made of before open3d tries: points on one line or in one plane
    (their spread across is under `FLAT_RATIO` of their extent), or coordinates whose squares, which
    the neighbour search takes, overflow."""
    extent = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    if not extent <= MAX_EXTENT:
        raise InputError(f"{name} is {extent:.3g} across: too large to measure distances in (at most "
                         f"{MAX_EXTENT:.0e}); scale it down")
    sample = points[:: max(1, len(points) // 100_000)]
    spread = np.linalg.svd((sample - sample.mean(axis=0)) / max(extent, np.finfo(float).tiny), compute_uv=False)
    if len(spread) < 3 or spread[1] <= FLAT_RATIO * spread[0]:
        raise InputError(f"{name} lies on a line: no solid can be made of it")
    if spread[2] <= FLAT_RATIO * spread[0]:
        raise InputError(f"{name} lies in a plane (a flat scan): no solid can be made of it")


def points_to_mesh(cloud, name="the point cloud"):
    """The closed surface of a cloud, by screened Poisson reconstruction.

    Returns
    -------
    trimesh.Trimesh
        Watertight and outward-oriented.

    Raises
    ------
    InputError
        Too sparse a cloud, or no consistent inside (the surface is not closed or encloses nothing).
    """
    o3d = load("open3d")

    points = cloud.point.positions.numpy().astype(np.float64)
    legacy = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    if "normals" in cloud.point:
        legacy.normals = o3d.utility.Vector3dVector(cloud.point.normals.numpy().astype(np.float64))
    legacy = legacy.remove_duplicated_points()
    _check_spread(np.asarray(legacy.points), name)
    size = float(np.ptp(np.asarray(legacy.points), axis=0).max())
    spacing = float(np.median(legacy.compute_nearest_neighbor_distance())) if len(legacy.points) > 1 else 0.0
    if len(legacy.points) < MIN_POINTS or not 0 < spacing * MAX_SPACING_RATIO <= size:
        raise InputError(f"{name} is too sparse: {len(legacy.points)} distinct points, {spacing:.3g} apart on a "
                         f"shape {size:.3g} across (at least {MIN_POINTS}, at most 1/{MAX_SPACING_RATIO} of "
                         "it apart, needed)")
    depth = int(np.clip(np.ceil(np.log2(size / spacing)), *DEPTH_RANGE))
    try:
        if not legacy.has_normals():
            # 50 neighbours for both: fewer flipped patches on sharp, bumpy scans (measured on fandisk
            # with stripes: Poisson surface 0.51 voxels from the mesh the points came from, 2.6 with 20/15).
            legacy.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=NEIGHBOURS))
            legacy.orient_normals_consistent_tangent_plane(NEIGHBOURS)
        surface, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(legacy, depth=depth)
    except RuntimeError as exc:  # qhull or Poisson giving up on a degenerate cloud
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{name} has no consistent inside: open3d could not orient or mesh it ({first})") \
            from None
    # Poisson's surface is closed but may have a few non-manifold edges; the voxelization does not mind.
    mesh = trimesh.Trimesh(np.asarray(surface.vertices), np.asarray(surface.triangles), process=True)
    if len(mesh.faces) == 0 or abs(mesh.volume) < MIN_VOLUME * size**3:
        raise InputError(f"{name} has no consistent inside: its Poisson surface encloses nothing "
                         "(a flat scan, or normals that do not agree)")
    if mesh.volume < 0:  # the normals pointed inwards throughout
        mesh.invert()
    return mesh


def move_points(cloud, mesh):
    """A copy of ``cloud`` with every point moved to the closest point of ``mesh``, attributes kept."""
    o3d = load("open3d")

    points = cloud.point.positions.numpy()
    closest = MeshSurface(mesh).closest_points(points)
    out = cloud.clone()
    out.point.positions = o3d.core.Tensor(closest.astype(points.dtype))
    return out


def save_points(cloud, path, protect=()):
    """Write a cloud (its format from the suffix), atomically."""
    o3d = load("open3d")

    from skelfilter.io.output_files import atomic_write

    def write(tmp):
        if not o3d.t.io.write_point_cloud(tmp, cloud):
            raise InputError(f"{path}: open3d could not write the point cloud")

    atomic_write(str(path), write, protect)
