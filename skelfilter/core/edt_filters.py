"""Filters of the skeleton's radii against 'EDT ripples' (thesis §6.2), and the clean-up of the reconstruction.

Every filter of §6.2: the kernel filters of eq. 6.1 (minification, mean, median, constrained opening),
implicit or explicit (`kernel_filter`), the least-squares projection (`least_squares`, eq. 6.2-6.4) and
the flat projection (`flat_projection`); `filtered_radii` picks one by name. The thesis finds the
implicit minification the best (Tables 6.1-6.2) and uses it with ``r = 3`` (§8.1.2). `specks` and
`needles` clean up what the filtered radii rebuild.
"""

import numpy as np
from numba import prange
from scipy import ndimage

from skelfilter.core.neighbourhood import OFFSETS_26, ball_offsets, bounding_box, flat_offsets, push, unravel
from skelfilter.errors import ParameterError
from skelfilter.runtime.compiled import njit


def minify(distance, centres, radius=3.0):
    """Implicit minification of the radii at the skeleton centres (§6.2.1).

    Parameters
    ----------
    distance : (nx, ny, nz) float array
        The EDT ``D`` of the shape ``X``: positive on ``X``, 0 outside.
    centres : (n,) array of int64
        Flat indices of the centres (the kept skeleton voxels).
    radius : float, optional
        Radius ``r`` of the ball in voxels, >= 0 (the thesis uses 3).

    Returns
    -------
    (n,) float32 array
        ``minf(x) = D_inf(x) + r`` where ``D(x) >= r``, else ``D_inf(x)``, with
        ``D_inf(x) = min{D(y) : y in X, |y - x| <= r}`` (eq. 6.1 with the infimum
        kernel). Centres outside ``X`` get 0 (eq. 6.1's "otherwise").

    Notes
    -----
    Voxels outside the volume are not in ``X``, so near the border the ball is
    clipped to the volume: that is eq. 6.1 itself, not an approximation. Only
    the centres are evaluated, each over the ``ball_offsets(radius)``.

    ``D`` is 1-Lipschitz and at least 1 on ``X``, so
    ``max(D(x) - r, 1) <= D_inf(x) <= D(x)``: where ``D(x) >= r`` the radius
    becomes ``minf`` in ``[max(D(x), 1 + r), D(x) + r]``, elsewhere it shrinks to
    ``[max(D(x) - r, 1), D(x)]``. Balls of the shallow centres, which make edges
    and corners, shrink: the filter cuts sharp corners (§6.3.3). Where
    ``r <= D(x) < r + 1`` the correction overshoots to ``1 + r``, which on a clean
    cube adds one layer of voxels along the edges (see the tests).

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §6.2.1, eq. 6.1.
    """
    return kernel_filter(distance, centres, "minify", radius)


@njit()
def _piece_sizes(labels, n):
    """Voxels per label 0..n (np.bincount would first copy the labels to int64)."""
    sizes = np.zeros(n + 1, np.int64)
    for label in labels.reshape(-1):
        sizes[label] += 1
    return sizes


@njit(parallel=True)
def _mark_pieces(labels, small, out):
    """``out |= small[labels]`` in place, without a temporary over the box."""
    for i in prange(labels.shape[0]):
        for j in range(labels.shape[1]):
            for k in range(labels.shape[2]):
                if small[labels[i, j, k]]:
                    out[i, j, k] = True


def specks(mask, radius=3.0):
    """Pieces and pockets of a reconstruction smaller than the minification ball.

    Minification shrinks the radii of shallow skeleton voxels (``D < r``),
    which can cut a thin part's last kept ball loose from the body, or leave
    a pocket between shrunk balls: specks of a few voxels below the filter's
    own scale. Returns the voxels whose state should flip: face-connected
    components of ``mask`` and of its complement (marching cubes can give
    a piece or a pocket joined only by an edge or a corner a surface of its
    own) with fewer voxels than a ball of ``radius`` (4/3 pi r^3); never
    the largest piece, never the outside.
    """
    limit = 4.0 / 3.0 * np.pi * radius**3
    flip = np.zeros_like(mask)
    # Only the box around the mask, one voxel wider, can hold specks: outside
    # it the complement is one piece with the box's outer layer, which has
    # the outside's fate (never flipped: it is the largest, or not small).
    crop = bounding_box(mask, margin=1)
    if crop is None:
        return flip
    inner = mask[crop]
    for target in (inner, ~inner):
        labels, n = ndimage.label(target)
        if n <= 1:
            continue
        sizes = _piece_sizes(labels, n)
        small = sizes < limit
        small[0] = False
        small[np.argmax(sizes[1:]) + 1] = False
        if small.any():
            _mark_pieces(labels, small, flip[crop])
    return flip


def needles(mask, max_neighbours=2):
    """Voxel-thin spikes of a reconstruction: voxels with at most ``max_neighbours`` set 26-neighbours.

    A kept skeleton line whose balls are smaller than a voxel (radius < 1 after
    minification and the half-voxel offset) rebuilds a column one voxel wide:
    a needle that marching cubes draws as a spike. Such voxels are peeled off
    from the tip inwards, each removal re-examining its neighbours, until none
    is left; a solid part never has a voxel this bare (the outermost corner of a
    cube has 7 set neighbours). Returns the voxels to clear.
    """
    flip = np.zeros_like(mask)
    crop = bounding_box(mask, margin=1)
    if crop is None:
        return flip
    inner = np.ascontiguousarray(mask[crop])
    found = np.zeros_like(inner)
    _peel(inner.reshape(-1), found.reshape(-1), flat_offsets(inner.shape, OFFSETS_26), inner.shape,
          max_neighbours)
    flip[crop] = found
    return flip


@njit()
def _peel(mask, found, steps, shape, max_neighbours):
    """Clear (in ``mask``) and mark (in ``found``) bare voxels, then the neighbours they leave bare."""
    nx, ny, nz = shape
    stack = np.empty(mask.size // 8 + 64, dtype=np.int64)
    top = 0
    for i in range(1, nx - 1):
        for j in range(1, ny - 1):
            for k in range(1, nz - 1):
                v = (i * ny + j) * nz + k
                if mask[v] and _count(mask, v, steps) <= max_neighbours:
                    stack, top = push(stack, top, v)
    while top > 0:
        top -= 1
        v = stack[top]
        if not mask[v] or _count(mask, v, steps) > max_neighbours:
            continue
        mask[v] = False
        found[v] = True
        for step in steps:
            u = v + step
            if mask[u]:
                stack, top = push(stack, top, u)


@njit()
def _count(mask, v, steps):
    n = 0
    for step in steps:
        n += mask[v + step]
    return n


# The kernels of eq. 6.1 that `kernel_filter` evaluates (minify is the minimum with its correction).
KERNELS = ("minify", "mean", "median", "opening")
_MIN, _MAX, _MEAN, _MEDIAN = 0, 1, 2, 3


@njit(parallel=True)
def _ball_reduce(values, coords, offsets, kind):
    """The kernel ``kind`` over the positive ``values`` within ``offsets`` of each of ``coords``; 0 where none."""
    nx, ny, nz = values.shape
    out = np.zeros(coords.shape[0], np.float64)
    for n in prange(coords.shape[0]):
        found = np.empty(offsets.shape[0], np.float64)
        count = 0
        for m in range(offsets.shape[0]):
            i = coords[n, 0] + offsets[m, 0]
            j = coords[n, 1] + offsets[m, 1]
            k = coords[n, 2] + offsets[m, 2]
            if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz and values[i, j, k] > 0:
                found[count] = values[i, j, k]
                count += 1
        if count == 0:
            continue
        if kind == 0:
            out[n] = found[:count].min()
        elif kind == 1:
            out[n] = found[:count].max()
        elif kind == 2:
            out[n] = found[:count].mean()
        else:
            out[n] = np.median(found[:count])
    return out


@njit()
def _mark_balls(marks, coords, offsets):
    nx, ny, nz = marks.shape
    for n in range(coords.shape[0]):
        for m in range(offsets.shape[0]):
            i = coords[n, 0] + offsets[m, 0]
            j = coords[n, 1] + offsets[m, 1]
            k = coords[n, 2] + offsets[m, 2]
            if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz:
                marks[i, j, k] = True


def _check(distance, centres, radius):
    if not np.isfinite(radius) or radius < 0:
        raise ParameterError(f"EDT filter radius must be a finite number >= 0, got {radius}")
    distance = np.asarray(distance)
    if distance.ndim != 3:
        raise ParameterError(f"distance must be a 3-D volume, got shape {distance.shape}")
    centres = np.asarray(centres, dtype=np.int64).ravel()
    if centres.size and (centres.min() < 0 or centres.max() >= distance.size):
        raise ParameterError("centres must be flat indices into the distance volume")
    return np.ascontiguousarray(distance), centres


def _crop(shape, coords, margin):
    """The box around ``coords`` widened by ``margin``, clipped to ``shape``, and the coords in it."""
    low = np.maximum(coords.min(axis=0) - margin, 0)
    high = np.minimum(coords.max(axis=0) + margin + 1, shape)
    return tuple(slice(int(a), int(b)) for a, b in zip(low, high)), coords - low


def kernel_filter(distance, centres, kernel, radius=3.0, explicit=False):
    """A kernel filter of the radii at the skeleton centres (eq. 6.1), implicit or explicit (§6.2.1).

    Parameters
    ----------
    distance : (nx, ny, nz) float array
        The EDT ``D`` of the shape ``X``: positive on ``X``, 0 outside.
    centres : (n,) int array
        Flat indices of the kept skeleton voxels.
    kernel : {'minify', 'mean', 'median', 'opening'}
        ``K`` of eq. 6.1 over the ball of ``radius``: the minimum followed by the correction ``+ r``
        where ``D(x) >= r`` (minification), the mean, the median, or the minimum followed by the
        maximum over the same ball (the constrained opening ``D_sup D_inf``).
    radius : float
        ``r`` in voxels.
    explicit : bool
        False: the kernel runs over every voxel of ``X`` in the ball (``D_bar``, implicit); True: over
        the centres in the ball only (``D_hat``, explicit), the core skeleton's own radii.

    Returns
    -------
    (n,) float32 array
        The filtered radii; a centre outside ``X`` gets 0 (eq. 6.1's "otherwise"). The mean, the median
        and the correction of minification can exceed ``D(x)``.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §6.2.1, eq. 6.1, Tables 6.1-6.2.
    """
    if kernel not in KERNELS:
        raise ParameterError(f"kernel must be one of {', '.join(KERNELS)}, got {kernel!r}")
    distance, centres = _check(distance, centres, radius)
    if not centres.size:
        return np.zeros(0, np.float32)
    offsets, _ = ball_offsets(radius)
    coords = unravel(centres, distance.shape)
    box, coords = _crop(distance.shape, coords, 2 * int(np.ceil(radius)) + 1)
    field = distance[box]
    d = field[tuple(coords.T)].astype(np.float64)
    inside = d > 0
    if explicit:
        field = np.zeros(field.shape, dtype=distance.dtype)
        field[tuple(coords.T)] = d
    if kernel == "opening":
        if explicit:
            at = coords
        else:  # D_inf is needed at every voxel of X that the maximum around a centre reads
            near = np.zeros(field.shape, dtype=np.bool_)
            _mark_balls(near, coords, offsets)
            at = np.argwhere(near & (field > 0))
        lowest = np.zeros(field.shape, dtype=np.float64)
        lowest[tuple(at.T)] = _ball_reduce(field, at, offsets, _MIN)
        out = _ball_reduce(lowest, coords, offsets, _MAX)
    else:
        out = _ball_reduce(field, coords, offsets, {"minify": _MIN, "mean": _MEAN, "median": _MEDIAN}[kernel])
        if kernel == "minify":
            out = np.where(d >= radius, out + radius, out)
    return np.where(inside, out, 0.0).astype(np.float32)


@njit(parallel=True)
def _plane_projection(lookup, coords, radii, offsets):
    nx, ny, nz = lookup.shape
    out = radii.astype(np.float64)
    for n in prange(coords.shape[0]):
        points = np.empty((offsets.shape[0], 4), np.float64)
        count = 0
        for m in range(offsets.shape[0]):
            i = coords[n, 0] + offsets[m, 0]
            j = coords[n, 1] + offsets[m, 1]
            k = coords[n, 2] + offsets[m, 2]
            if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz and lookup[i, j, k] >= 0:
                points[count, 0], points[count, 1], points[count, 2] = i, j, k
                points[count, 3] = radii[lookup[i, j, k]]
                count += 1
        if count < 3:
            continue
        mean = np.zeros(4)
        for c in range(count):
            mean += points[c]
        mean /= count
        centred = points[:count] - mean
        _, vectors = np.linalg.eigh(centred.T @ centred)  # eigenvalues ascending
        plane = np.ascontiguousarray(vectors[:, 2:])  # W_2: the two largest
        here = np.array([coords[n, 0], coords[n, 1], coords[n, 2], radii[n]], np.float64) - mean
        out[n] = (plane @ (plane.T @ here))[3] + mean[3]  # eq. 6.4
    return out


def least_squares(distance, centres, radius=3.0):
    """Least-squares projection of the radii (eq. 6.2-6.4, §6.2.2).

    Each centre ``x`` is mapped to ``P(x) = (x1, x2, x3, D(x))`` (eq. 6.2); the centres within ``radius``
    (itself included) give a local 2-plane in that 4-space, the two largest principal directions of their
    covariance (eq. 6.3), and the radius becomes the fourth coordinate of ``P(x)`` projected on that plane
    (eq. 6.4). A centre with fewer than 3 such neighbours keeps ``D(x)``.

    Returns
    -------
    (n,) float32 array

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §6.2.2, eq. 6.2-6.4.
    """
    distance, centres = _check(distance, centres, radius)
    if not centres.size:
        return np.zeros(0, np.float32)
    offsets, _ = ball_offsets(radius)
    box, coords = _crop(distance.shape, unravel(centres, distance.shape), int(np.ceil(radius)) + 1)
    lookup = np.full(tuple(s.stop - s.start for s in box), -1, dtype=np.int64)
    lookup[tuple(coords.T)] = np.arange(len(centres))
    radii = distance.reshape(-1)[centres].astype(np.float64)
    return _plane_projection(lookup, coords, radii, offsets).astype(np.float32)


def flat_projection(distance, centres, a, b):
    """Radii shrunk off the segments between the feature points of pruned skeleton voxels (§6.2.3).

    A pruned (ligature) voxel's feature points ``a`` and ``b`` lie on either side of the noise it made,
    and the segment between them runs along the base of that noise. Each kept ball is shrunk so that
    it no longer crosses any such segment: its radius becomes ``min(D(x), d(x))`` with ``d`` the
    distance from ``x`` to the nearest segment. The thesis leaves the method's details out (its results
    were poor); here every pruned voxel's segment counts, sampled every half voxel and rounded to the
    voxel grid, and ``d`` is the EDT to those samples, linear in the grid.

    Parameters
    ----------
    distance : (nx, ny, nz) float array
    centres : (n,) int array
        Flat indices of the kept skeleton voxels.
    a, b : (m, 3) int arrays
        The feature points of the pruned skeleton voxels.

    Returns
    -------
    (n,) float32 array

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §6.2.3, Fig. 6.3.
    """
    distance, centres = _check(distance, centres, 0.0)
    radii = distance.reshape(-1)[centres].astype(np.float32)
    a = np.asarray(a, dtype=np.float64).reshape(-1, 3)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 3)
    if not len(a) or not centres.size:
        return radii
    steps = np.maximum(np.ceil(2 * np.linalg.norm(b - a, axis=1)).astype(np.int64), 1)
    owner = np.repeat(np.arange(len(a)), steps + 1)
    t = (np.arange(len(owner)) - np.repeat(np.cumsum(steps + 1) - (steps + 1), steps + 1)) / steps[owner]
    samples = np.rint(a[owner] + t[:, None] * (b - a)[owner]).astype(np.int64)
    samples = np.clip(samples, 0, np.array(distance.shape) - 1)
    free = np.ones(distance.shape, dtype=bool)
    free[tuple(samples.T)] = False
    to_segment = ndimage.distance_transform_edt(free).reshape(-1)[centres]
    return np.minimum(radii, to_segment).astype(np.float32)


def filtered_radii(edt_filter, distance, centres, radius=3.0, pruned_features=None):
    """The radii of the kept skeleton voxels after the EDT filter named ``edt_filter`` (§6.2).

    ``minify``, ``mean``, ``median``, ``opening`` and their ``explicit-`` forms: `kernel_filter` (the
    implicit minification through `minify`, capped at ``D``: on a discrete EDT, ``D >= 1`` on ``X``, its
    correction can exceed ``D`` by up to 1); ``least-squares``: `least_squares`; ``flat``:
    `flat_projection` with ``pruned_features``, the pair ``(a, b)`` of the pruned voxels' feature
    points; ``none``: ``D``.
    """
    if edt_filter == "none":
        return np.asarray(distance).reshape(-1)[centres].astype(np.float32)
    if edt_filter == "minify":
        return np.minimum(minify(distance, centres, radius), np.asarray(distance).reshape(-1)[centres])
    if edt_filter == "least-squares":
        return least_squares(distance, centres, radius)
    if edt_filter == "flat":
        return flat_projection(distance, centres, *pruned_features)
    explicit = edt_filter.startswith("explicit-")
    return kernel_filter(distance, centres, edt_filter.removeprefix("explicit-"), radius, explicit)
