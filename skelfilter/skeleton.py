"""Surface skeletons: the IE and IMA rules (thesis §7.1.1) and the extended feature transform (eq. 2.6)."""

import numpy as np

from .distance import gradient_at
from .neighbourhood import OFFSETS_6, OFFSETS_26, flat_offsets, unravel


def ie_skeleton(distance):
    """Implicit Euclidean (IE) surface skeleton, eq. 7.7.

    ``E(x) = D(x) * sqrt(1 - |grad D(x)|^2) >= 1`` with the gradient by
    central differences; ``1 - |grad D|^2`` is clamped at 0 because the
    discrete gradient can exceed unit length a little.

    Parameters
    ----------
    distance : float ndarray
        EDT of the set; the set must not touch the volume's faces.

    Returns
    -------
    skeleton : int64 ndarray
        Sorted flat indices of the skeleton voxels.
    """
    inside = np.flatnonzero(distance.reshape(-1) > 0)
    g = gradient_at(distance, inside)
    slack = np.maximum(0.0, 1.0 - (g * g).sum(axis=1))
    e = distance.reshape(-1)[inside] * np.sqrt(slack)  # eq. 7.7
    return inside[e >= 1.0]


def ima_skeleton(volume, features):
    """Integer medial axis (IMA) skeleton, eq. 7.1–7.2.

    ``x`` is a skeleton voxel when, for some face neighbour ``x + e`` in X,
    the feature points are more than 1 apart (eq. 7.1; the text reads
    "larger than one": with ``>= 1`` any two distinct integer feature points
    qualify and a cube would be all skeleton) and ``f(x + e)`` is no farther
    than ``f(x)`` from the midpoint ``m = x + e/2`` (eq. 7.2).
    """
    shape = volume.shape
    flat = volume.reshape(-1)
    inside = np.flatnonzero(flat)
    fx = features[(slice(None),) + np.unravel_index(inside, shape)].T.astype(np.int64)
    x = unravel(inside, shape)
    is_skeleton = np.zeros(len(inside), dtype=bool)
    for e, step in zip(OFFSETS_6, flat_offsets(shape, OFFSETS_6)):
        neighbour = inside + step
        both = flat[neighbour]
        fy = features[(slice(None),) + np.unravel_index(neighbour[both], shape)].T.astype(np.int64)
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
    the first (READING-NOTES, "Which two feature points").

    Returns
    -------
    a, b : (n, 3) int64 ndarrays
        Voxel coordinates of the two feature points.
    """
    shape = volume.shape
    flat = volume.reshape(-1)
    a = features[(slice(None),) + np.unravel_index(skeleton, shape)].T.astype(np.int64)
    b = a.copy()
    best = np.zeros(len(skeleton), dtype=np.int64)
    for step in flat_offsets(shape, OFFSETS_26):
        y = skeleton + step
        ok = flat[y]
        fy = features[(slice(None),) + np.unravel_index(y[ok], shape)].T.astype(np.int64)
        d2 = ((fy - a[ok]) ** 2).sum(axis=1)
        idx = np.flatnonzero(ok)
        better = d2 > best[idx]
        best[idx[better]] = d2[better]
        b[idx[better]] = fy[better]
    return a, b
