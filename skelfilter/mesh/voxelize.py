"""Mesh to occupancy volume on a grid, robust to open and unmerged meshes.

`Grid` is the lattice of voxel centres in world coordinates; `voxelize` fits one to a mesh and
`voxelize_on_grid` samples a mesh on a given one: a voxel is inside when its centre is inside the
mesh, as told by the ray votes of :mod:`skelfilter.mesh.ray_votes`.
"""

from dataclasses import dataclass

import numpy as np
import trimesh

from skelfilter.errors import InputError, ParameterError
from skelfilter.mesh.ray_votes import occupancy


@dataclass(frozen=True)
class Grid:
    """A regular voxel grid; voxel ``(i, j, k)`` has its centre at ``origin + (i, j, k) * pitch``.

    Attributes
    ----------
    origin : ndarray, shape (3,)
        World position of the centre of voxel ``(0, 0, 0)``.
    pitch : float
        World length of a voxel edge.
    shape : tuple of int
        ``(nx, ny, nz)``.
    """

    origin: np.ndarray
    pitch: float
    shape: tuple

    def __post_init__(self):
        origin = np.array(self.origin, dtype=np.float64).reshape(3)
        origin.flags.writeable = False
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "pitch", float(self.pitch))
        object.__setattr__(self, "shape", tuple(int(n) for n in self.shape))

    # The generated field-wise comparison would compare ``origin`` element-wise.
    def __eq__(self, other):
        if not isinstance(other, Grid):
            return NotImplemented
        return (
            self.shape == other.shape
            and self.pitch == other.pitch
            and np.array_equal(self.origin, other.origin)
        )

    def __hash__(self):
        return hash((self.shape, self.pitch, self.origin.tobytes()))

    def to_world(self, ijk):
        """World positions of ``(n, 3)`` voxel coordinates (fractional ones allowed)."""
        return np.asarray(ijk, dtype=np.float64) * self.pitch + self.origin

    def to_index(self, xyz):
        """Fractional voxel coordinates of ``(n, 3)`` world positions."""
        return (np.asarray(xyz, dtype=np.float64) - self.origin) / self.pitch

    @property
    def n_voxels(self):
        """Number of voxels in the grid."""
        return int(np.prod(self.shape))


def grid_for_bounds(bounds, resolution, padding):
    """Grid with ``resolution`` voxels along the longest side of ``bounds``.

    Parameters
    ----------
    bounds : array_like, shape (2, 3)
        World minimum and maximum corners.
    resolution : int
        Voxels along the longest side, at least 16; ``pitch = longest extent / resolution``.
    padding : int
        Empty voxels added on every side.

    Returns
    -------
    Grid
        Per axis ``max(1, ceil(extent / pitch)) + 2 * padding`` voxels, with
        the bounds centred in the block of voxel cells.

    Raises
    ------
    ParameterError
        On a resolution below 16, a negative padding, or bounds that are not
        finite or have a zero longest side.
    """
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)) or resolution < 16:
        raise ParameterError(f"resolution must be an integer >= 16, got {resolution!r}")
    if isinstance(padding, bool) or not isinstance(padding, (int, np.integer)) or padding < 0:
        raise ParameterError(f"padding must be an integer >= 0, got {padding!r}")
    b = np.asarray(bounds, dtype=np.float64)
    if b.shape != (2, 3) or not np.isfinite(b).all():
        raise ParameterError("bounds must be a finite (2, 3) array of min and max corners")
    extent = b[1] - b[0]
    if extent.min() < 0 or extent.max() <= 0:
        raise ParameterError(f"bounds are degenerate: extents {extent.tolist()}")
    pitch = extent.max() / resolution
    # The tolerance keeps the longest side at exactly `resolution` despite rounding.
    cells = np.maximum(1, np.ceil(extent / pitch - 1e-9)).astype(np.int64) + 2 * int(padding)
    origin = (b[0] + b[1]) / 2 - (cells - 1) / 2 * pitch
    return Grid(origin, pitch, tuple(cells.tolist()))


def grid_on_lattice(bounds, pitch, anchor, padding):
    """Grid whose voxel centres lie on the lattice ``anchor + k * pitch`` (k integer) and cover
    ``bounds``, with ``padding`` voxels more on every side.

    This is a voxel mesh's own grid (`voxel_lattice`): voxelized on it, a marching-cubes mesh gives
    back the voxels it was made of.
    """
    b = np.asarray(bounds, dtype=np.float64)
    anchor = np.asarray(anchor, dtype=np.float64)
    first = np.floor((b[0] - anchor) / pitch) - int(padding)
    last = np.ceil((b[1] - anchor) / pitch) + int(padding)
    return Grid(anchor + first * pitch, pitch, tuple((last - first + 1).astype(np.int64).tolist()))


# A vertex coordinate lies on a lattice plane when within this share of the pitch of one (files keep
# 6 to 9 significant digits); a voxel mesh has at least `LATTICE_SHARE` of its vertices on lattice
# edges (two coordinates on planes) and at least `EDGE_SHARE` with the third between two planes.
LATTICE_TOLERANCE = 1e-3
LATTICE_SHARE = 0.99
EDGE_SHARE = 0.5
# Faces, and vertices, the lattice is measured on at most (a random sample, fixed seed).
LATTICE_SAMPLE = 50_000


def voxel_lattice(mesh):
    """The voxel lattice a marching-cubes mesh was made on, or None: ``(pitch, anchor)``.

    Marching cubes puts every vertex on an edge between two neighbouring voxel centres: two of its
    coordinates are those of lattice planes ``anchor + k * pitch``. Between the two ends of a mesh
    edge such a coordinate changes by 0 or one pitch, so the pitch is among the most frequent
    coordinate changes along the edges; each candidate (largest first) is tried: its planes on each
    axis are the residue shared by most vertices, and the lattice holds when `LATTICE_SHARE` of the
    vertices have two coordinates or more on planes and `EDGE_SHARE` exactly two. Meshes whose
    vertices lie on no lattice (scans, CAD models, smoothed or decimated voxel meshes) give None.
    """
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if len(vertices) < 100 or len(faces) == 0:
        return None
    extent = float(np.ptp(vertices, axis=0).max())
    if not extent > 0:
        return None
    rng = np.random.default_rng(0)
    if len(faces) > LATTICE_SAMPLE:
        faces = faces[rng.choice(len(faces), LATTICE_SAMPLE, replace=False)]
    step = np.abs(vertices[faces] - vertices[np.roll(faces, 1, axis=1)]).reshape(-1)
    quantum = extent * 1e-7
    changes, counts = np.unique(np.round(step[step > 1e3 * quantum] / quantum), return_counts=True)
    sample = vertices[rng.choice(len(vertices), min(len(vertices), LATTICE_SAMPLE), replace=False)]
    for pitch in np.sort(changes[np.argsort(counts)[-4:]] * quantum)[::-1]:
        anchor = np.empty(3)
        for axis in range(3):
            residue = np.round(np.mod(sample[:, axis] / pitch, 1.0) / LATTICE_TOLERANCE).astype(np.int64)
            residue %= int(round(1 / LATTICE_TOLERANCE))
            anchor[axis] = np.bincount(residue).argmax() * LATTICE_TOLERANCE * pitch
        offset = (sample - anchor) / pitch
        planes = (np.abs(offset - np.round(offset)) <= LATTICE_TOLERANCE).sum(axis=1)
        if np.mean(planes >= 2) >= LATTICE_SHARE and np.mean(planes == 2) >= EDGE_SHARE:
            return float(pitch), anchor
    return None


# The automatic resolution: voxels per mean edge length along the longest side, and its range.
VOXELS_PER_EDGE = 2.0
AUTO_RESOLUTION_RANGE = (96, 256)


def auto_resolution(mesh):
    """A grid resolution for ``mesh``: `VOXELS_PER_EDGE` voxels per mean edge length along the
    longest side of its bounding box, within `AUTO_RESOLUTION_RANGE`.

    A voxel then resolves what the mesh resolves, and finer grids would only cost time.
    """
    extent = float(np.ptp(np.asarray(mesh.bounds, dtype=np.float64), axis=0).max())
    edge = float(np.asarray(mesh.edges_unique_length).mean()) if len(mesh.faces) else 0.0
    lo, hi = AUTO_RESOLUTION_RANGE
    if not edge > 0:
        return hi
    return int(np.clip(round(VOXELS_PER_EDGE * extent / edge), lo, hi))


def voxelize(mesh, resolution=256, padding=8):
    """Occupancy volume of a mesh on a grid fitted to its bounding box.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Triangle mesh; it may be open or a triangle soup (see `voxelize_on_grid`).
    resolution : int, optional
        Voxels along the longest side of the bounding box.
    padding : int, optional
        Empty voxels added around the shape on every side.

    Returns
    -------
    volume : ndarray of bool, shape grid.shape
        True where the voxel centre is inside the mesh.
    grid : Grid
        The grid of `volume`, from `grid_for_bounds` on the mesh's bounds.

    Raises
    ------
    InputError
        If the mesh has no faces, non-finite vertex coordinates, or all its
        vertices at one point.
    ParameterError
        If `resolution` or `padding` is out of range.
    """
    vertices, faces = _triangles(mesh)
    used = vertices[np.unique(faces)]
    bounds = np.stack([used.min(axis=0), used.max(axis=0)])
    if (bounds[1] == bounds[0]).all():
        raise InputError("all the mesh's vertices coincide")
    grid = grid_for_bounds(bounds, resolution, padding)
    return occupancy(vertices, faces, grid), grid


def why_empty(mesh, grid):
    """Why ``mesh`` encloses no voxel centre of ``grid``, in words for the user."""
    parts = mesh.split(only_watertight=False) if len(mesh.faces) else []
    extents = np.array([np.ptp(p.vertices, axis=0) for p in parts]).reshape(-1, 3)
    across = np.ptp(np.asarray(mesh.vertices), axis=0).max() / grid.pitch
    voxel = f"1/{across:.0f} of the mesh's longest side"
    if len(parts) > 1 and (extents.max(axis=1) < grid.pitch).all():
        return (f"its {len(parts)} parts are each smaller than a voxel ({voxel}): they lie far apart for their size; "
                "denoise them one at a time")
    if len(extents) and (extents.min(axis=1) < 2 * grid.pitch).all():
        return f"it is thinner than two voxels (a voxel is {voxel}): flat, or raise `resolution`"
    return "it encloses nothing: is it an open surface?"


def voxelize_on_grid(mesh, grid):
    """Occupancy of a mesh on a given grid: True where the voxel centre is inside.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Triangle mesh. It need not be watertight nor merged: inside/outside
        comes from ray-parity votes along the three axes, and rays that went
        through a hole (odd number of crossings) do not vote.
    grid : Grid
        Where to sample.

    Returns
    -------
    ndarray of bool, shape grid.shape

    Raises
    ------
    InputError
        If the mesh has no faces or non-finite vertex coordinates.

    Notes
    -----
    A voxel whose three rays are valid and agree is certain. Otherwise it
    takes the majority of two or three valid votes; failing that (a tie, or
    one valid ray at most, which happens only next to holes) it looks along
    its three rays: the surface is not crossed between two consecutive
    crossings, so the voxels of such a stretch share one true state, and the
    voxel takes the sign of the summed mean decision (+1 inside, -1 outside)
    of the decided voxels of its three stretches, outside on a zero sum.
    Last, the outside voxels that are not certain and are cut off (through
    face neighbours) from the certain outside and the grid's border would be
    cavities made next to holes: they are filled. Voids of a closed mesh are
    certain and stay. Time is linear in the number of voxels plus the number
    of ray/triangle crossings; memory is one byte per voxel plus per-ray
    arrays.

    References
    ----------
    .. [1] F. S. Nooruddin, G. Turk, "Simplification and repair of polygonal models using volumetric
           techniques", IEEE TVCG 9(2), 2003.
    """
    return occupancy(*_triangles(mesh), grid)


def _triangles(mesh):
    """Vertices (float64) and faces (int64) of a mesh whose triangles can be voxelized."""
    if not isinstance(mesh, trimesh.Trimesh):
        raise InputError(f"expected a trimesh.Trimesh, got {type(mesh).__name__}")
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if len(faces) == 0:
        raise InputError("the mesh has no faces")
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    if not np.isfinite(vertices).all(axis=1)[faces].all():
        raise InputError("the mesh has NaN or infinite vertex coordinates")
    return vertices, faces
