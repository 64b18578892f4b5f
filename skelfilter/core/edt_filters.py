"""Filters of the skeleton's radii against 'EDT ripples' (thesis §6.2.1).

Only the implicit minification filter is provided: the thesis finds it the best
of the kernel filters (Tables 6.1-6.2) and uses it with ``r = 3`` (§8.1.2).
"""

import numpy as np
from numba import njit, prange
from scipy import ndimage

from skelfilter.core.neighbourhood import OFFSETS_26, ball_offsets, bounding_box, flat_offsets, push, unravel
from skelfilter.errors import ParameterError


@njit(cache=True, parallel=True)
def _ball_min(distance, coords, offsets):
    nx, ny, nz = distance.shape
    out = np.empty(coords.shape[0], np.float64)
    for n in prange(coords.shape[0]):
        x, y, z = coords[n, 0], coords[n, 1], coords[n, 2]
        best = np.inf
        for m in range(offsets.shape[0]):
            i = x + offsets[m, 0]
            j = y + offsets[m, 1]
            k = z + offsets[m, 2]
            if 0 <= i < nx and 0 <= j < ny and 0 <= k < nz:
                d = distance[i, j, k]
                if 0 < d < best:
                    best = d
        out[n] = best if best < np.inf else 0.0
    return out


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
    if not np.isfinite(radius) or radius < 0:
        raise ParameterError(f"minification radius must be a finite number >= 0, got {radius}")
    distance = np.asarray(distance)
    if distance.ndim != 3:
        raise ParameterError(f"distance must be a 3-D volume, got shape {distance.shape}")
    centres = np.asarray(centres, dtype=np.int64).ravel()
    if centres.size and (centres.min() < 0 or centres.max() >= distance.size):
        raise ParameterError("centres must be flat indices into the distance volume")
    distance = np.ascontiguousarray(distance)
    offsets, _ = ball_offsets(radius)
    # Visiting the centres in memory order keeps neighbouring balls in cache.
    order = np.argsort(centres, kind="stable")
    d_inf = np.empty(centres.size, dtype=np.float64)
    d_inf[order] = _ball_min(distance, unravel(centres[order], distance.shape), offsets)
    deep = distance.ravel()[centres] >= radius
    return np.where(deep, d_inf + radius, d_inf).astype(np.float32)


@njit(cache=True)
def _piece_sizes(labels, n):
    """Voxels per label 0..n (np.bincount would first copy the labels to int64)."""
    sizes = np.zeros(n + 1, np.int64)
    for label in labels.reshape(-1):
        sizes[label] += 1
    return sizes


@njit(cache=True, parallel=True)
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


@njit(cache=True)
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


@njit(cache=True)
def _count(mask, v, steps):
    n = 0
    for step in steps:
        n += mask[v + step]
    return n
