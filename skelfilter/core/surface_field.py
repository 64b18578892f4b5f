"""The continuous field whose 0-level is the output surface: balls' union of a binary volume, the
input's own distances kept where the denoising changed nothing, and the field smoothed under the
voxels' constraint so that its surface is smooth and still encloses exactly the voxels it is of."""

import numpy as np
from numba import prange
from scipy import ndimage
from scipy.spatial import cKDTree

from skelfilter.core import reconstruct
from skelfilter.core.distance import gradient_at
from skelfilter.core.gaussian_filter import gaussian_filter
from skelfilter.core.neighbourhood import dilated_by_cross
from skelfilter.runtime.compiled import njit

# Balls of radius D touch the centres of the nearest outside voxels; the
# boundary between inside and outside voxel centres is half a voxel further in.
SURFACE_OFFSET = 0.5
# The sign-constrained smoothing (`smooth_constrained`): the Gaussian's sigma in voxels of the grid
# (along each axis, so thick slices are smoothed over as many slices as thin ones over pixels), and
# the rounds of smoothing then projection. Chosen on benchmarks/surfaces.py's tuning label maps.
SMOOTHING_SIGMA = 0.8
SMOOTHING_ROUNDS = 3
# Voxels: how far inside (outside) its voxel centre's value is held at least, so no vertex of the
# marching cubes lands on a centre (no triangle without area).
CONSTRAINT_MARGIN = 0.02
# Voxels: how far `signed_distance_at` looks for a voxel's nearest voxel of the other side before it
# falls back to whole-grid distance transforms; the band it is asked about lies at the surface, where
# the nearest such voxel is one or two voxels away.
NEAREST_REACH = 4
# Voxels of the finest axis: the reach over which the smoothed surface is moved to enclose its voxels'
# volume (`match_voxel_volume`); wide enough that the sampling's jitter averages out along the surface,
# narrow enough that a thin part and the thick one it leaves are matched each on its own.
VOLUME_MATCH_SCALE = 4.0


def axis_sigmas(spacing, sigma=SMOOTHING_SIGMA):
    """The smoothing's sigma along each axis of a grid of ``spacing``, in its voxels: ``sigma`` along the
    finest axis, and along a coarser one less by the square root of how much coarser (a slice twice as
    thick: 0.57 slices, 1.13 in-plane pixels), between the same number of voxels on every axis, which
    rounds off what thick slices leave of a thin part, and the same length, which leaves their
    terraces."""
    spacing = np.asarray(spacing, dtype=float)
    return tuple(float(s) for s in sigma * np.sqrt(spacing.min() / spacing))


def unchanged_band(field, mask, occupancy, reach):
    """Flat indices of the voxels whose field values shape the 0-level (``|field| < 1.5``) and lie
    more than ``reach`` voxels (6-connected steps) from any voxel the denoising changed.

    Only the band's voxels are looked at, each against the voxels within ``reach`` steps of it (the
    grid's outside changes nothing): ``reach`` dilations of the changes over the whole grid, less
    their cost."""
    band = np.flatnonzero(((field < 1.5) & (field > -1.5)).reshape(-1))
    span = np.arange(-reach, reach + 1)
    offsets = np.stack(np.meshgrid(span, span, span, indexing="ij"), axis=-1).reshape(-1, 3)
    offsets = offsets[np.abs(offsets).sum(axis=1) <= reach]
    mask = np.ascontiguousarray(mask, dtype=bool)
    occupancy = np.ascontiguousarray(occupancy, dtype=bool)
    return band[_far_from_change(mask, occupancy, band, offsets)]


@njit(parallel=True)
def _far_from_change(mask, occupancy, voxels, offsets):
    """Whether no voxel at the ``offsets`` from each flat index in ``voxels`` differs between the two."""
    nx, ny, nz = mask.shape
    far = np.ones(len(voxels), dtype=np.bool_)
    for n in prange(len(voxels)):
        v = voxels[n]
        i, j, k = v // (ny * nz), (v // nz) % ny, v % nz
        for o in range(len(offsets)):
            a, b, c = i + offsets[o, 0], j + offsets[o, 1], k + offsets[o, 2]
            if 0 <= a < nx and 0 <= b < ny and 0 <= c < nz and mask[a, b, c] != occupancy[a, b, c]:
                far[n] = False
                break
    return far


def put_distances(field, mask, band, distance):
    """``field[band]`` = ``distance`` with the mask's sign, so the mesh and the voxels still agree."""
    flat = field.reshape(-1)
    flat[band] = np.where(mask.reshape(-1)[band], 1.0, -1.0) * np.maximum(np.abs(distance), 1e-3)


def keep_input_field(field, mask, occupancy, input_field=None, reach=2):
    """`skelfilter.mesh.marching_cubes.keep_input_surface` for a volume: where the denoising changed
    nothing, ``field`` takes the input's own ``input_field`` (in voxels, > 0 inside, e.g.
    `skelfilter.core.spacing.signed_distance`; None: the occupancy's signed distance on cubic voxels,
    `signed_distance_at` the voxels it is read at). In place."""
    band = unchanged_band(field, mask, occupancy, reach)
    distance = signed_distance_at(occupancy, band) if input_field is None else input_field.reshape(-1)[band]
    put_distances(field, mask, band, distance)


def signed_distance_at(mask, indices):
    """``skelfilter.core.spacing.signed_distance(mask, (1.0, 1.0, 1.0))`` at the flat ``indices``, bit
    for bit, without its two whole-grid distance transforms: each voxel's nearest voxel of the other
    side is looked for among the offsets within `NEAREST_REACH`, nearest first; only where one is
    found there is it looked for among the voxels of the other side next to its own (the nearest
    voxel of the other side is one of them: its neighbour towards the voxel is nearer, so of the
    voxel's side), with a k-d tree."""
    mask = np.ascontiguousarray(mask, dtype=bool)
    indices = np.asarray(indices, dtype=np.int64)
    steps = np.arange(-NEAREST_REACH, NEAREST_REACH + 1)
    offsets = np.stack(np.meshgrid(steps, steps, steps, indexing="ij"), axis=-1).reshape(-1, 3)
    squared = (offsets ** 2).sum(axis=1)
    order = np.argsort(squared, kind="stable")
    within = squared[order] <= NEAREST_REACH ** 2
    offsets, squared = offsets[order][within][1:], squared[order][within][1:]  # the voxel itself left out
    found = _nearest_other_side(mask.reshape(-1), np.asarray(mask.shape, dtype=np.int64), indices,
                                offsets.astype(np.int64), squared.astype(np.int64))
    # signed_distance's (inside - outside) / 2 with one of the two 0 (a voxel's own side is at 0)
    distance = np.sqrt(np.maximum(found, 0).astype(np.float64))
    inside = mask.reshape(-1)[indices]
    missing = found < 0
    for side in (True, False):
        far = missing & (inside == side)
        if far.any():
            distance[far] = _nearest_by_tree(mask if side else ~mask, indices[far])
    return (np.where(inside, distance - 0.0, 0.0 - distance) / 2).astype(np.float32)


def _nearest_by_tree(own, indices):
    """Distance from each voxel of the flat ``indices`` (set in ``own``) to its nearest voxel not
    in ``own``, exactly as the whole-grid transform gives it (the square root of an integer)."""
    other = dilated_by_cross(own) & ~own
    if not other.any():  # no other side on the grid: whatever the transform makes of that
        return ndimage.distance_transform_edt(own).reshape(-1)[indices]
    targets = np.argwhere(other)
    points = np.stack(np.unravel_index(indices, own.shape), axis=-1)
    _, nearest = cKDTree(targets).query(points)
    # the square root of the integer squared distance, as the transform takes it
    return np.sqrt(((targets[nearest] - points) ** 2).sum(axis=1).astype(np.float64))


@njit()
def _nearest_other_side(flat, shape, indices, offsets, squared):
    """Squared distance from each voxel of ``indices`` to the first of ``offsets`` (nearest first)
    where ``flat`` differs from it; -1 where none does."""
    nx, ny, nz = shape[0], shape[1], shape[2]
    found = np.full(indices.size, -1, dtype=np.int64)
    for i in range(indices.size):
        index = indices[i]
        x, y, z = index // (ny * nz), (index // nz) % ny, index % nz
        side = flat[index]
        for k in range(offsets.shape[0]):
            a, b, c = x + offsets[k, 0], y + offsets[k, 1], z + offsets[k, 2]
            if 0 <= a < nx and 0 <= b < ny and 0 <= c < nz and flat[(a * ny + b) * nz + c] != side:
                found[i] = squared[k]
                break
    return found


def mask_field(mask):
    """Continuous field of a binary volume: the union of the balls of all its voxels.

    Same construction as the pipeline's reconstruction without pruning, so
    meshes of noisy and of denoised volumes are extracted alike.
    """
    distance = ndimage.distance_transform_edt(mask)
    centres = np.flatnonzero(mask.reshape(-1))
    radii = distance.reshape(-1)[centres] - SURFACE_OFFSET
    return reconstruct.union_of_balls(mask.shape, centres, radii)[1]


def smooth_constrained(field, inside, fixed=None, spacing=(1.0, 1.0, 1.0), rounds=SMOOTHING_ROUNDS,
                       match_volume=True, overwrite=False):
    """The smoothest field near ``field`` whose sign at every voxel centre is ``inside``'s.

    A voxel mask is the sampling of a smooth surface: each set voxel's centre lies inside it, each
    other centre outside, and nothing more is known of where between two centres it passes. Each
    round smooths the field by a low-pass that does not shrink (twicing of a Gaussian,
    ``2 G f - G G f``: its response ``1 - (1 - g)^2`` is flat to fourth order, so a sphere or a
    cylinder keeps its radius where a Gaussian would move its surface in by its curvature times
    sigma squared), then puts every voxel centre back on its own side of the surface (at least
    `CONSTRAINT_MARGIN` voxels' worth of field) and ``fixed`` voxels back to their values. Pressed
    against the inside centres where it rounds a convex staircase off, the surface then encloses less
    than its voxels (a thin part across thick slices a tenth less): with ``match_volume``,
    `match_voxel_volume` moves it out by what is missing there. The marching cubes of the result
    encloses exactly the ``inside`` voxels, staircase removed.

    Parameters
    ----------
    field : float ndarray
        > 0 inside; in any unit common to the axes (e.g. `skelfilter.core.spacing.signed_distance`
        in world units).
    inside : bool ndarray
        The voxels whose centres must stay inside, same shape.
    fixed : bool ndarray, optional
        Voxels whose values are kept as they are (a surface already known to sub-voxel precision).
    spacing : sequence of 3 floats
        A voxel's size along each axis in the field's unit: sets the margin, the Gaussian's sigma along
        each axis (`axis_sigmas`) and the volume a voxel stands for.
    rounds : int
    overwrite : bool
        ``field`` (float32, C-contiguous) may be smoothed in place and returned: one grid less.
    match_volume : bool
        Move the surface to its voxels' volume (`match_voxel_volume`): for voxels that sample a smooth
        surface (a label map). Not for the voxels a pruning left, whose removed bumps' stubs the
        rounding takes down.

    Returns
    -------
    float32 ndarray
        The smoothed field.

    References
    ----------
    .. [1] R. T. Whitaker, "Reducing aliasing artifacts in iso-surfaces of binary volumes", IEEE
           Symposium on Volume Visualization 2000 (the sign constraint at the voxel centres).
    .. [2] V. Lempitsky, "Surface extraction from binary volumes with higher-order smoothness",
           CVPR 2010 (a higher-order smoothness: no shrinking).
    .. [3] J. W. Tukey, *Exploratory data analysis*, 1977 ("twicing").

    Examples
    --------
    >>> import numpy as np
    >>> i, j, k = np.indices((24, 24, 24)) - 11.5
    >>> ball = i**2 + j**2 + k**2 < 8.3**2
    >>> from skelfilter.core.spacing import signed_distance
    >>> field = smooth_constrained(signed_distance(ball, (1.0, 1.0, 1.0)), ball)
    >>> bool(((field > 0) == ball).all())
    True
    """
    inside = np.asarray(inside, dtype=bool)
    given = field
    field = np.ascontiguousarray(field, dtype=np.float32)
    held = None if fixed is None else field[fixed]
    spacing = np.asarray(spacing, dtype=float)
    sigma = axis_sigmas(spacing)
    current = field if overwrite or field is not given else field.copy()  # a converted field is a copy already
    # Two arrays for the filter's passes, reused every round (fresh memory costs more than the filter).
    once, scratch = np.empty_like(current), np.empty_like(current)
    for _ in range(rounds):
        gaussian_filter(current, sigma, "nearest", out=once, scratch=scratch)  # scipy's, over the cores
        gaussian_filter(once, sigma, "nearest", out=current, scratch=scratch)
        np.multiply(once, 2, out=scratch)
        np.subtract(scratch, current, out=current)  # 2 G f - G G f
        _constrain(current, inside, held, fixed, spacing)
    del once, scratch
    if match_volume:
        current += match_voxel_volume(current, inside, spacing, fixed)
        _constrain(current, inside, held, fixed, spacing)
    return current


def _constrain(field, inside, held, fixed, spacing):
    """Every voxel centre back on its side by `CONSTRAINT_MARGIN` voxels at least, ``fixed`` voxels to
    their ``held`` values; in place."""
    margin = np.float32(CONSTRAINT_MARGIN * spacing.min())
    np.maximum(field, margin, out=field, where=inside)
    np.minimum(field, -margin, out=field, where=~inside)
    if fixed is not None:
        field[fixed] = held


def match_voxel_volume(field, inside, spacing, fixed=None, scale=VOLUME_MATCH_SCALE):
    r"""How far to move the 0-level of ``field`` out (> 0) or in, near each voxel, for the surface to
    enclose the volume of its ``inside`` voxels there.

    Along a grid line, the voxels' volume is what a surface crossing each edge between an inside and
    an outside centre half-way encloses; one crossing it at ``t`` of the edge from the inside centre
    (the marching cubes' crossing, linear in the field) encloses ``(t - 1/2) h_a`` more, per cell of
    cross-section ``h_b h_c``. A surface of unit normal ``n`` is crossed by edges along axis ``a`` at
    ``|n_a| / (h_b h_c)`` per unit area, so moving it out by ``c`` adds ``c`` per unit area along every
    axis; weighting each axis' edges by ``|n_a|^2`` (most crossings, least slant) the volume to add
    near a point and the area there are

    .. math:: \Delta V = \sum_e |n_a|^2 (1/2 - t_e) h_a h_b h_c, \qquad
              A = \sum_e |n_a| h_b h_c,

    both summed over the crossed edges with a Gaussian weight of ``scale`` voxels, and the move is
    ``c = \Delta V / A``: the local mean of ``|n_a| (1/2 - t_e) h_a``, at most half a voxel. Edges next to
    a ``fixed`` voxel count for nothing.

    Parameters
    ----------
    field : float32 ndarray
        > 0 inside, in the unit of ``spacing``.
    inside : bool ndarray
    spacing : sequence of 3 floats
    fixed : bool ndarray, optional
    scale : float
        Sigma of the Gaussian weight, in voxels of the finest axis.

    Returns
    -------
    float32 ndarray
        The move, in the field's unit; 0 far from the surface.
    """
    spacing = np.asarray(spacing, dtype=float)
    shape = field.shape
    flat = field.reshape(-1)
    strides = np.array([int(np.prod(shape[a + 1:])) for a in range(3)])
    # The Gaussian weight is wide: the sums are gathered on blocks of voxels about a quarter of its
    # sigma on a side, and the move read back by linear interpolation where the surface passes.
    sigma = scale * spacing.min() / spacing
    block = np.maximum(1, (sigma / 2).astype(int))
    coarse = tuple(int(n) for n in -(-np.asarray(shape) // block))
    added = np.zeros(int(np.prod(coarse)), dtype=np.float64)
    area = np.zeros_like(added)
    for axis in range(3):
        lo = tuple(slice(None, -1) if a == axis else slice(None) for a in range(3))
        hi = tuple(slice(1, None) if a == axis else slice(None) for a in range(3))
        crossed = inside[lo] != inside[hi]
        if fixed is not None:
            crossed &= ~(fixed[lo] | fixed[hi])
        index = np.ravel_multi_index(np.nonzero(crossed), shape)  # the lower voxel of each crossed edge
        lower_inside = inside.reshape(-1)[index]
        own = np.where(lower_inside, index, index + strides[axis])
        other = np.where(lower_inside, index + strides[axis], index)
        t = flat[own] / (flat[own] - flat[other])
        normal = gradient_at(field, own) / spacing
        slant = np.abs(normal[:, axis]) / np.maximum(np.linalg.norm(normal, axis=1), 1e-12)
        cell = spacing.prod() / spacing[axis]
        into = np.ravel_multi_index(tuple(i // b for i, b in zip(np.unravel_index(own, shape), block)), coarse)
        added += np.bincount(into, slant**2 * (0.5 - t) * spacing[axis] * cell, minlength=added.size)
        area += np.bincount(into, slant * cell, minlength=area.size)
    added = ndimage.gaussian_filter(added.reshape(coarse), sigma / block, mode="constant")
    area = ndimage.gaussian_filter(area.reshape(coarse), sigma / block, mode="constant")
    mean = np.zeros(coarse, dtype=np.float64)
    np.divide(added, area, out=mean, where=area > 1e-6 * area.max())
    move = np.zeros(shape, dtype=np.float32)
    near = np.nonzero(np.abs(field) < 2 * spacing.max())  # the voxels whose values shape the 0-level
    at = [(i + 0.5) / b - 0.5 for i, b in zip(near, block)]
    move[near] = ndimage.map_coordinates(mean, at, order=1, mode="nearest")
    return move
