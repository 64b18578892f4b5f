"""Euclidean distance transform and feature transform (thesis §2.2, eq. 2.4–2.5).

The feature transform is Maurer, Qi & Raghavan's separable algorithm (the one
``scipy.ndimage.distance_transform_edt`` implements), with scipy's tie-breaking
so both give the same feature points: one pass per axis, each linear in the
number of voxels, in parallel over lines. Features are carried as flat int32
indices (4 bytes per voxel) and the distances come out as float32.
"""

import math

import numpy as np
from numba import prange

from skelfilter.runtime.compiled import njit


def distance_and_features(volume):
    """EDT ``D`` of a set and, per voxel, one nearest background voxel.

    Parameters
    ----------
    volume : (nx, ny, nz) bool ndarray
        The set X. It must leave at least one background voxel.

    Returns
    -------
    distance : float32 ndarray
        ``D(x) = min {|x - y| : y not in X}`` (eq. 2.4); 0 on the background,
        so foreground voxels touching the background have ``D = 1``.
    features : (nx, ny, nz) int32 ndarray
        Flat index of one element ``f(x)`` of the feature transform ``F(x)``
        (eq. 2.5), the one scipy's ``distance_transform_edt`` returns. For
        ``x`` in X it lies in the boundary layer ``M = (X ⊕ b) \\ X`` (eq. 7.12).

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §2.2, eq. 2.4-2.5.
    .. [2] C. R. Maurer, R. Qi, V. Raghavan, "A linear time algorithm for computing exact Euclidean
           distance transforms of binary images in arbitrary dimensions", IEEE TPAMI 25(2), 2003.
    """
    volume = np.ascontiguousarray(volume, dtype=bool)
    if volume.all():
        raise ValueError("the set fills the whole volume: no background to measure distances to")
    if volume.size >= 2**31:
        raise ValueError(f"a grid of {volume.size} voxels is too large for int32 feature indices")
    features = np.empty(volume.shape, dtype=np.int32)
    distance = np.empty(volume.shape, dtype=np.float32)
    _first_axis(volume, features, True)
    _other_axes(features, distance, True)
    return distance, features


def distance_transform(volume):
    """EDT ``D`` of a set (eq. 2.4) without the feature transform: float32, equal to
    ``distance_and_features(volume)[0]`` (the square roots of the same integers).

    The same three passes carry squared distances instead of feature indices, so the passes across
    the first axis read a number per voxel instead of working one out from a flat index, and the
    transform moves half the bytes. For the morphology of the later steps (closings, heights above a
    shape), which read no feature point. ``volume`` as for `distance_and_features`; returns ``D``
    (float32, 0 on the background).

    Examples
    --------
    >>> import numpy as np
    >>> cube = np.zeros((7, 7, 7), bool); cube[1:6, 1:6, 1:6] = True
    >>> float(distance_transform(cube)[3, 3, 3])
    3.0
    """
    volume = np.ascontiguousarray(volume, dtype=bool)
    if volume.all():
        raise ValueError("the set fills the whole volume: no background to measure distances to")
    squared = np.empty(volume.shape, dtype=np.int32)
    _first_axis(volume, squared, False)
    # The last pass reads a whole line before it writes that line's distances: they take its place.
    distance = squared.view(np.float32)
    _other_axes(squared, distance, False)
    return distance


def feature_points(features, voxels):
    """Flat indices (int64) of the feature points ``f(x)`` of the given flat voxel indices."""
    return features.reshape(-1)[voxels].astype(np.int64)


def gradient_at(distance, voxels):
    """Central-difference gradient of ``distance`` at flat voxel indices, shape ``(n, 3)``, in voxel
    units; one-sided on the volume's faces."""
    flat = distance.reshape(-1)
    shape = distance.shape
    strides = (shape[1] * shape[2], shape[2], 1)
    ijk = np.unravel_index(voxels, shape)
    g = np.empty((len(voxels), 3), dtype=np.float32)
    for axis, s in enumerate(strides):
        ahead = np.where(ijk[axis] + 1 < shape[axis], voxels + s, voxels)
        behind = np.where(ijk[axis] > 0, voxels - s, voxels)
        g[:, axis] = (flat[ahead] - flat[behind]) / np.maximum((ahead - behind) // s, 1)
    return g


@njit(parallel=True)
def _first_axis(volume, out, features):
    """Nearest background voxel along axis 0, ties to the lower index: its flat index (``features``)
    or its squared distance (else); -1 where the line has none."""
    nx, ny, nz = volume.shape
    for j in prange(ny):
        # Forward sweep: the last background voxel at or before i ...
        last = np.full(nz, -1, np.int64)
        for i in range(nx):
            for k in range(nz):
                if not volume[i, j, k]:
                    last[k] = i
                out[i, j, k] = last[k]
        # ... backward sweep: the next one at or after i; the nearer wins.
        ahead = np.full(nz, -1, np.int64)
        for i in range(nx - 1, -1, -1):
            for k in range(nz):
                if not volume[i, j, k]:
                    ahead[k] = i
                behind = out[i, j, k]
                if behind < 0 or (ahead[k] >= 0 and ahead[k] - i < i - behind):
                    behind = ahead[k]
                if behind < 0:
                    out[i, j, k] = -1
                elif features:
                    out[i, j, k] = (behind * ny + j) * nz + k
                else:
                    out[i, j, k] = (behind - i) * (behind - i)


@njit()
def _voronoi_line(perp, nearest, out_d2, sites):
    """Maurer's Voronoi step on one line, as scipy's ``_VoronoiFT`` does it (exactly, in integers).

    ``perp[q]`` is the squared distance across the line of the site at position ``q`` along it (-1:
    no site there). A site is dropped when its two neighbours hide it (strictly), and each element
    takes the nearest remaining site, ties to the lower position: the choices scipy makes.
    ``nearest[q]`` receives that site's position and ``out_d2[q]`` its squared distance; on a line
    without sites ``nearest`` is -1 throughout and ``out_d2`` is left as it was.
    """
    n = perp.size
    top = -1
    for q in range(n):
        if perp[q] < 0:
            continue
        while top >= 1:
            p1 = sites[top]
            p0 = sites[top - 1]
            a = p1 - p0
            b = q - p1
            c = a + b
            if c * perp[p1] - b * perp[p0] - a * perp[q] - a * b * c <= 0:
                break
            top -= 1
        top += 1
        sites[top] = q
    if top < 0:
        nearest[:] = -1
        return
    last = top
    top = 0
    for q in range(n):
        p = sites[top]
        d1 = (p - q) * (p - q) + perp[p]
        while top < last:
            p = sites[top + 1]
            d2 = (p - q) * (p - q) + perp[p]
            if d1 <= d2:
                break
            d1 = d2
            top += 1
        nearest[q] = sites[top]
        out_d2[q] = d1


@njit()
def _feature_line(ids, perp, nearest, out, out_d2, sites):
    """The Voronoi step on a line of features: ``out[q]`` the feature nearest to ``q``."""
    _voronoi_line(perp, nearest, out_d2, sites)
    for q in range(ids.size):
        out[q] = -1 if nearest[q] < 0 else ids[nearest[q]]


@njit()
def _perpendicular(ids, perp, ny, nz, i, j, k, axis):
    """Squared distance from ``(i, j, k)`` to each feature, leaving out ``axis``."""
    for q in range(ids.size):
        f = ids[q]
        if f < 0:
            perp[q] = -1
            continue
        d0 = f // (ny * nz) - i
        d1 = f // nz % ny - j
        d2 = f % nz - k
        perp[q] = (d0 * d0 if axis != 0 else 0) + (d1 * d1 if axis != 1 else 0) + (d2 * d2 if axis != 2 else 0)


@njit()
def _line(values, perp, nearest, d2, sites, out, ny, nz, i, j, k, axis, features):
    """One line's Voronoi step, in place: ``values`` carry features (flat indices) or squared
    distances (-1: none); ``d2`` receives the squared distances."""
    n = values.size
    if features:
        _perpendicular(values, perp, ny, nz, i, j, k, axis)
        _feature_line(values, perp[:n], nearest, out[:n], d2, sites)
        values[:] = out[:n]
    else:
        perp[:n] = values
        _voronoi_line(perp[:n], nearest[:n], d2, sites)
        for q in range(n):
            values[q] = d2[q] if nearest[q] >= 0 else -1


@njit(parallel=True)
def _other_axes(grid, distance, features):
    """The passes along axes 1 and 2, plane by plane (both stay in one plane of axis 0), on features
    or squared distances (`_first_axis`); ``distance`` may be ``grid`` itself seen as float32 (each
    line is read whole before its distances are written)."""
    B = 16  # lines along axis 1 handled together, so reads and writes use whole cache lines
    nx, ny, nz = grid.shape
    n = max(ny, nz)
    for i in prange(nx):
        line = np.empty(n, np.int32)
        out = np.empty(n, np.int32)
        perp = np.empty(n, np.int64)
        d2 = np.empty(n, np.int64)
        sites = np.empty(n, np.int64)
        nearest = np.empty(n, np.int64)
        tile = np.empty((B, ny), np.int32)
        for k0 in range(0, nz, B):
            nb = min(B, nz - k0)
            for j in range(ny):
                for b in range(nb):
                    tile[b, j] = grid[i, j, k0 + b]
            for b in range(nb):
                _line(tile[b], perp, nearest, d2, sites, out, ny, nz, i, 0, k0 + b, 1, features)
            for j in range(ny):
                for b in range(nb):
                    grid[i, j, k0 + b] = tile[b, j]
        for j in range(ny):
            line[:nz] = grid[i, j]
            _line(line[:nz], perp, nearest, d2, sites, out, ny, nz, i, j, 0, 2, features)
            if features:
                grid[i, j] = line[:nz]
            for k in range(nz):
                distance[i, j, k] = math.sqrt(d2[k])
