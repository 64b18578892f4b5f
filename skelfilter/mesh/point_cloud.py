"""Point clouds denoised: a scanner's points made into a solid, denoised as a mesh, and the points
moved back (their files: :mod:`skelfilter.io.point_files`).

The solid comes from screened Poisson reconstruction (Kazhdan & Hoppe 2013) from the points'
normals, estimated (principal axes of the nearest neighbours) and oriented consistently (a minimum
spanning tree over the neighbours) when the file has none. The octree depth follows the points'
spacing, so Poisson keeps what the points resolve. What it needs, in short: a closed scan (the
points all round the object, or the Poisson surface bulges over the gaps), at least `MIN_POINTS`
points, and a spacing of at most 1/`MAX_SPACING_RATIO` of the longest side.

References
----------
.. [1] M. Kazhdan, H. Hoppe, "Screened Poisson surface reconstruction", ACM TOG 32(3), 2013.
"""

import numpy as np
import trimesh

from skelfilter.errors import InputError
from skelfilter.io.point_files import MIN_POINTS
from skelfilter.mesh.closest_points import MeshSurface
from skelfilter.runtime import native_output
from skelfilter.runtime.extras import need

FLAT_RATIO = 1e-6  # relative spread across below which a cloud is a line or a plane
MAX_EXTENT = 1e150  # squared distances stay finite
# The median nearest-neighbour spacing (duplicates removed) must stay under the longest side over this.
MAX_SPACING_RATIO = 60
DEPTH_RANGE = (6, 10)
# Neighbours of a point for its normal and for orienting the normals.
NEIGHBOURS = 50
# The least volume of the solid, over the cube of the longest side.
MIN_VOLUME = 1e-3


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
    o3d = need("open3d", "point clouds")

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
    estimated = not legacy.has_normals()
    try:
        if estimated:
            # 50 neighbours for both: fewer flipped patches on sharp, bumpy scans (measured on fandisk
            # with stripes: Poisson surface 0.51 voxels from the mesh the points came from, 2.6 with 20/15).
            legacy.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=NEIGHBOURS))
            legacy.orient_normals_consistent_tangent_plane(NEIGHBOURS)
        mesh = _poisson(o3d, legacy, depth)
        if estimated and _encloses_nothing(mesh, size):
            # The propagation over the neighbours flipped whole patches (a noisy fandisk: 42 % of the
            # normals point out); a closed scan's normals point away from its centre nearly everywhere.
            points = np.asarray(legacy.points)
            legacy.orient_normals_towards_camera_location(points.mean(axis=0))
            legacy.normals = o3d.utility.Vector3dVector(-np.asarray(legacy.normals))
            mesh = _poisson(o3d, legacy, depth)
    except RuntimeError as exc:  # qhull or Poisson giving up on a degenerate cloud
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{name} has no consistent inside: open3d could not orient or mesh it ({first})") \
            from None
    if _encloses_nothing(mesh, size):
        raise InputError(f"{name} has no consistent inside: its Poisson surface encloses nothing "
                         "(a flat scan, or normals that do not agree)")
    if mesh.volume < 0:  # the normals pointed inwards throughout
        mesh.invert()
    return mesh


def _poisson(o3d, cloud, depth):
    """open3d's screened Poisson surface of an oriented legacy cloud, as a trimesh (closed, but it may
    have a few non-manifold edges; the voxelization does not mind)."""
    with native_output.captured():  # PoissonRecon's warnings, which say nothing to a user
        surface, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(cloud, depth=depth)
    return trimesh.Trimesh(np.asarray(surface.vertices), np.asarray(surface.triangles), process=True)


def _encloses_nothing(mesh, size):
    """Whether a Poisson surface encloses less than `MIN_VOLUME` of the cube of ``size``."""
    return len(mesh.faces) == 0 or abs(mesh.volume) < MIN_VOLUME * size**3


def move_points(cloud, mesh):
    """A copy of ``cloud`` with every point moved to the closest point of ``mesh``, attributes kept."""
    o3d = need("open3d", "point clouds")

    points = cloud.point.positions.numpy()
    closest = MeshSurface(mesh).closest_points(points)
    out = cloud.clone()
    out.point.positions = o3d.core.Tensor(closest.astype(points.dtype))
    return out


