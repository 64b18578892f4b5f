"""Surface skeletons: the IE and IMA rules (thesis §7.1.1) and the extended feature transform (eq. 2.6)."""

import numpy as np
from numba import prange

from skelfilter.core.neighbourhood import OFFSETS_6, OFFSETS_26, flat_offsets, unravel
from skelfilter.runtime.compiled import njit


def ie_skeleton(distance):
    """Implicit Euclidean (IE) surface skeleton, eq. 7.7.

    ``E(x) = D(x) * sqrt(1 - |grad D(x)|^2) >= 1`` with the gradient by
    central differences; ``1 - |grad D|^2`` is clamped at 0 because the
    discrete gradient can exceed unit length a little.

    Parameters
    ----------
    distance : float32 ndarray
        EDT of the set; the set must not touch the volume's faces.

    Returns
    -------
    skeleton : int64 ndarray
        Sorted flat indices of the skeleton voxels.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §7.1.1, eq. 7.3-7.7.
    """
    distance = np.ascontiguousarray(distance, dtype=np.float32)
    marks = np.zeros(distance.shape, dtype=np.bool_)
    _ie_rule(distance, marks)
    return np.flatnonzero(marks.reshape(-1))


@njit(parallel=True)
def _ie_rule(distance, marks):
    # float32 throughout, summed in the order x, y, z: the arithmetic of gradient_at.
    nx, ny, nz = distance.shape
    for i in prange(1, nx - 1):
        for j in range(1, ny - 1):
            for k in range(1, nz - 1):
                d = distance[i, j, k]
                if d <= 0:
                    continue
                gx = np.float32(0.5) * (distance[i + 1, j, k] - distance[i - 1, j, k])
                gy = np.float32(0.5) * (distance[i, j + 1, k] - distance[i, j - 1, k])
                gz = np.float32(0.5) * (distance[i, j, k + 1] - distance[i, j, k - 1])
                slack = max(np.float32(0.0), np.float32(1.0) - (gx * gx + gy * gy + gz * gz))
                marks[i, j, k] = d * np.sqrt(slack) >= 1.0  # eq. 7.7


def ima_skeleton(volume, features):
    """Integer medial axis (IMA) skeleton, eq. 7.1–7.2.

    ``x`` is a skeleton voxel when, for some face neighbour ``x + e`` in X,
    the feature points are more than 1 apart (eq. 7.1; the text reads
    "larger than one": with ``>= 1`` any two distinct integer feature points
    qualify and a cube would be all skeleton) and ``f(x + e)`` is no farther
    than ``f(x)`` from the midpoint ``m = x + e/2`` (eq. 7.2).

    ``features`` holds flat feature indices, as from `distance_and_features`.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §7.1.1, eq. 7.1-7.2.
    .. [2] W. H. Hesselink, J. B. T. M. Roerdink, "Euclidean skeletons of digital image and volume
           data in linear time by the integer medial axis transform", IEEE TPAMI 30(12), 2008.
    """
    shape = volume.shape
    flat = volume.reshape(-1)
    feat = features.reshape(-1)
    inside = np.flatnonzero(flat)
    fx = unravel(feat[inside], shape)
    x = unravel(inside, shape)
    is_skeleton = np.zeros(len(inside), dtype=bool)
    for e, step in zip(OFFSETS_6, flat_offsets(shape, OFFSETS_6)):
        neighbour = inside + step
        both = flat[neighbour]
        fy = unravel(feat[neighbour[both]], shape)
        fxb = fx[both]
        apart = ((fy - fxb) ** 2).sum(axis=1) > 1  # eq. 7.1
        m2 = 2 * x[both] + e  # twice the midpoint keeps the test in integers
        closer = ((m2 - 2 * fy) ** 2).sum(axis=1) <= ((m2 - 2 * fxb) ** 2).sum(axis=1)  # eq. 7.2
        is_skeleton[np.flatnonzero(both)[apart & closer]] = True
    return inside[is_skeleton]


def extended_feature_points(volume, features, skeleton):
    """The two feature points of each skeleton voxel (eq. 2.6 with eq. 3.6's Euclidean proxy).

    The first is the voxel's own feature point ``f(x)``; the second is, among
    the feature points of ``x``'s 26-neighbours in X, the one farthest from
    the first (READING-NOTES, "Which two feature points"); the first in the
    order of ``OFFSETS_26`` among equally far ones.

    Parameters
    ----------
    volume : (nx, ny, nz) bool ndarray
        The set X; the skeleton must not touch the volume's faces.
    features : (nx, ny, nz) int32 ndarray
        Flat feature indices, as from `distance_and_features`.
    skeleton : (n,) int64 ndarray
        Flat indices of the skeleton voxels.

    Returns
    -------
    a, b : (n,) int64 ndarrays
        Flat indices of the two feature points.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §2.2, eq. 2.6.
    """
    shape = volume.shape
    skeleton = np.asarray(skeleton, dtype=np.int64)
    a = features.reshape(-1)[skeleton].astype(np.int64)
    b = _farthest_neighbour_feature(volume.reshape(-1), features.reshape(-1), skeleton, a,
                                    flat_offsets(shape, OFFSETS_26), shape[1], shape[2])
    return a, b


@njit(parallel=True)
def _farthest_neighbour_feature(flat, feat, skeleton, a, steps, ny, nz):
    b = a.copy()
    for n in prange(skeleton.size):
        ax, ay, az = a[n] // (ny * nz), a[n] // nz % ny, a[n] % nz
        best = 0
        for step in steps:
            y = skeleton[n] + step
            if not flat[y]:
                continue
            f = feat[y]
            dx, dy, dz = f // (ny * nz) - ax, f // nz % ny - ay, f % nz - az
            d2 = dx * dx + dy * dy + dz * dz
            if d2 > best:
                best = d2
                b[n] = f
    return b
