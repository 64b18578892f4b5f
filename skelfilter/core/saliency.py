"""Derivative measure and streamline importance rho+ (thesis §4.2, §5.2.1 and §5.2.2).

Everything here works on flat arrays over the skeleton voxels, linked by
their 26-adjacency; ``rho`` exists only on the skeleton, so its derivative
is taken from skeleton neighbours only (§4.2.1).
"""

import numba
import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from skelfilter.core.distance import gradient_at
from skelfilter.core.neighbourhood import OFFSETS_26, flat_offsets, unravel

# A skeleton step y - x counts as "along v" when its cosine with v(x) is at
# least this: the cone the derivative measure steps in and that rho+ is
# taken from (the discrete streamlines of eq. 5.1).
STREAM_COSINE = 0.5


def skeleton_adjacency(skeleton, shape):
    """26-adjacency among skeleton voxels as a CSR pair ``(indptr, indices)``.

    ``skeleton`` holds flat voxel indices; neighbours are referred to by
    their position in that array, each voxel's in the order of
    ``OFFSETS_26``. The skeleton must not touch the volume's faces.
    """
    n = len(skeleton)
    skeleton = np.asarray(skeleton, dtype=np.int64)
    lookup = np.full(int(np.prod(shape)), -1, dtype=np.int32)
    lookup[skeleton] = np.arange(n, dtype=np.int32)
    steps = flat_offsets(shape, OFFSETS_26)
    counts = _neighbour_count(lookup, skeleton, steps)
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=indptr[1:])
    indices = np.empty(indptr[-1], dtype=np.int32)
    _neighbour_fill(lookup, skeleton, steps, indptr, indices)
    return indptr, indices


@numba.njit(cache=True, parallel=True)
def _neighbour_count(lookup, skeleton, steps):
    counts = np.zeros(skeleton.size, dtype=np.int64)
    for i in numba.prange(skeleton.size):
        for step in steps:
            counts[i] += lookup[skeleton[i] + step] >= 0
    return counts


@numba.njit(cache=True, parallel=True)
def _neighbour_fill(lookup, skeleton, steps, indptr, indices):
    for i in numba.prange(skeleton.size):
        p = indptr[i]
        for step in steps:
            j = lookup[skeleton[i] + step]
            if j >= 0:
                indices[p] = j
                p += 1


def feature_velocity(skeleton, shape, a, b):
    """Feature-point velocity field ``v(x) = x - (a+ + a-)/2`` (eq. 4.16), shape ``(n, 3)``.

    It lies in the skeleton's tangent plane and points to growing ``D``.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §4.2.1, eq. 4.16.
    """
    x = unravel(skeleton, shape).astype(np.float32)
    return x - 0.5 * (a + b).astype(np.float32)


def edt_gradient_velocity(distance, skeleton):
    """Velocity field ``v(x) = grad D(x)`` by central differences (eq. 4.7).

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §4.2.1, eq. 4.7.
    """
    return gradient_at(distance, skeleton)


def derivative_measure(rho, distance, skeleton, velocity, adjacency, guard=0.1, min_cosine=STREAM_COSINE,
                       min_rho=0.0):
    """Derivative measure ``sigma_bar = (grad rho . v) / (grad D . v)`` (eq. 4.2).

    Both directional derivatives are taken along the same step on the
    skeleton: from ``x`` to its 26-neighbour ``y`` on the skeleton that best
    follows ``v(x)`` (largest cosine, at least ``min_cosine``), as the
    discrete streamlines of eq. 5.1 do. Then
    ``sigma_bar = (rho(y) - rho(x)) / (D(y) - D(x))``; the length of ``v``
    and of the step cancel, as in eq. 4.2. Inside a ligature sheet the step
    stays on voxels with the same feature points, so ``sigma_bar`` is 0.

    Parameters
    ----------
    min_rho : float
        Below this importance the measure is left undefined, like eq. 4.3's
        guard. Geodesics and EDT values are quantized by the grid (steps of
        1, sqrt 2, sqrt 3 and square roots of integers), so on structures a few
        voxels across (the voxel steps of slanted or curved surfaces) the
        one-step ratio is quantization noise, not the ligature signal.

    Returns
    -------
    sigma_bar : float32 ndarray
        NaN where ``D`` grows by less than ``guard`` per voxel along the step
        (eq. 4.3), where no skeleton neighbour lies ahead along ``v``, or where
        ``rho < min_rho``: there the measure is undefined and the voxel is
        never a ligature candidate.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §4.2, eq. 4.2-4.3.
    """
    indptr, indices = adjacency
    coords = unravel(skeleton, distance.shape).astype(np.float64)
    d_skel = distance.reshape(-1)[skeleton].astype(np.float64)
    rho = np.asarray(rho, dtype=np.float64)
    sigma = _step_ratio(coords, rho, d_skel, np.asarray(velocity, dtype=np.float64), indptr, indices,
                        guard, min_cosine)
    sigma[rho < min_rho] = np.nan
    return sigma


@numba.njit(cache=True, parallel=True)
def _step_ratio(coords, rho, dist, velocity, indptr, indices, guard, min_cosine):
    n = coords.shape[0]
    out = np.full(n, np.nan, dtype=np.float32)
    for i in numba.prange(n):
        v0, v1, v2 = velocity[i, 0], velocity[i, 1], velocity[i, 2]
        vn = np.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        if vn == 0.0:
            continue
        best, best_j, best_len = min_cosine, -1, 1.0
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            d0 = coords[j, 0] - coords[i, 0]
            d1 = coords[j, 1] - coords[i, 1]
            d2 = coords[j, 2] - coords[i, 2]
            length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            cosine = (d0 * v0 + d1 * v1 + d2 * v2) / (length * vn)
            if cosine >= best:
                best, best_j, best_len = cosine, j, length
        if best_j < 0:
            continue
        rise = dist[best_j] - dist[i]
        if rise < guard * best_len:  # eq. 4.3
            continue
        out[i] = (rho[best_j] - rho[i]) / rise  # eq. 4.2
    return out


def rho_plus(rho, sigma_bar, adjacency, k=0.9, velocity=None, skeleton=None, shape=None,
             min_cosine=STREAM_COSINE, min_rho=0.0):
    """Global streamline importance ``rho+`` (eq. 5.6), optionally along ``v`` (eq. 5.1).

    Voxels are visited in decreasing ``rho`` (ties by position). The first
    (the root) and every low-derivative voxel (``sigma_bar <= k``) keep
    ``rho+ = rho``; any other takes the largest ``rho+`` among its already
    visited 26-neighbours, or keeps ``rho`` when it has none (a local
    maximum, READING-NOTES). NaN ``sigma_bar`` (undefined, eq. 4.3) is never
    low-derivative. Linear after the sort.

    With ``velocity`` (and ``skeleton``, ``shape``) the neighbours a voxel
    may take ``rho+`` from are those ahead of it along ``v``, within the
    cone ``cos(v, y - x) >= min_cosine`` that the derivative measure steps
    in: the recursion then follows the streamlines of eq. 5.1 (whose path
    steps to the neighbour best aligned with ``v``) instead of spreading to
    every higher neighbour, so core importance no longer leaks sideways
    along noise sheets of equal ``rho``. Voxels with ``rho < min_rho`` (the
    voxel-scale structures on which ``v`` and ``sigma_bar`` are undefined,
    see :func:`derivative_measure`) and voxels with ``v = 0`` take it from
    any visited neighbour, as in eq. 5.6. Without ``velocity`` this is eq.
    5.6 as printed.

    Returns
    -------
    rho_plus : float32 ndarray
        ``rho_plus >= rho`` everywhere.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §5.2.2, eq. 5.6.
    """
    indptr, indices = adjacency
    rho = np.asarray(rho, dtype=np.float32)
    order = np.argsort(-rho, kind="stable").astype(np.int64)
    ligature = np.asarray(sigma_bar <= k)  # NaN compares False
    if velocity is None:  # eq. 5.6 as printed: every visited neighbour counts
        coords = velocity = np.zeros((len(rho), 3))
        cone = np.full(len(rho), -np.inf)
    else:
        coords = unravel(skeleton, shape).astype(np.float64)
        velocity = np.asarray(velocity, dtype=np.float64)
        cone = np.where(rho < min_rho, -np.inf, min_cosine)
    return _rho_plus_cone(rho, ligature, order, indptr, indices, coords, velocity, cone)


@numba.njit(cache=True)
def _rho_plus_cone(rho, ligature, order, indptr, indices, coords, velocity, cone):
    n = rho.shape[0]
    out = rho.copy()
    rank = np.empty(n, dtype=np.int64)
    for r in range(n):
        rank[order[r]] = r
    for r in range(1, n):
        i = order[r]
        if ligature[i]:
            continue
        v0, v1, v2 = velocity[i, 0], velocity[i, 1], velocity[i, 2]
        vn = np.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        best = -np.inf
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            if rank[j] >= r or out[j] <= best:
                continue
            if vn > 0.0:
                d0 = coords[j, 0] - coords[i, 0]
                d1 = coords[j, 1] - coords[i, 1]
                d2 = coords[j, 2] - coords[i, 2]
                length = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                if (d0 * v0 + d1 * v1 + d2 * v2) < cone[i] * length * vn:
                    continue
            best = out[j]
        if best > -np.inf:
            out[i] = best
    return out


def thin_part(voxels, a_flat, b_flat, radius, shape, min_radius, min_angle=150.0):
    """Skeleton voxels in the middle of a thin part: feature points on opposite sides, ball not small.

    A voxel of a plate, a wall or a rim has its two feature points straight
    across (the angle between ``a - x`` and ``b - x``, the object angle, near
    180°), and the radius of its ball is half the part's thickness. Ligature
    voxels, which eq. 5.6 is built to prune, have a small object angle; the
    axis of a noise protrusion has a large one but a ball no wider than the
    protrusion. Voxels with object angle >= ``min_angle`` and ``radius >=
    min_radius`` are therefore kept whatever their importance: near the rim of
    a thin wall the geodesic between the two sides is short (about the
    thickness plus twice the distance to the rim) and the velocity of
    eq. 4.16 vanishes, so rho+ cannot inherit importance there.

    Parameters
    ----------
    voxels, a_flat, b_flat : int ndarray
        Flat indices of the skeleton voxels and of their two feature points.
    radius : float ndarray
        D at the skeleton voxels.
    shape : tuple of int
    min_radius : float
        Least ball radius (half thickness), in voxels.
    min_angle : float, optional
        Least object angle, degrees.

    Returns
    -------
    bool ndarray, aligned with ``voxels``
    """
    candidates = np.flatnonzero(radius >= min_radius)
    x = unravel(voxels[candidates], shape).astype(np.float32)
    to_a = unravel(a_flat[candidates], shape) - x
    to_b = unravel(b_flat[candidates], shape) - x
    cosine = (to_a * to_b).sum(axis=1) / np.maximum(
        np.linalg.norm(to_a, axis=1) * np.linalg.norm(to_b, axis=1), 1e-12)
    out = np.zeros(len(voxels), dtype=bool)
    out[candidates[cosine <= np.cos(np.radians(min_angle))]] = True
    return out


def detached_noise(kept, adjacency, radius, max_radius):
    """Kept skeleton pieces cut off from the rest by the pruning, all of whose balls are small.

    Pruning the ligature of a protrusion whose own axis inherited importance
    leaves that axis as an island of kept voxels; its balls rebuild a needle
    or a blob standing on the surface. A connected component (26-adjacency)
    of the kept voxels whose largest radius is below ``max_radius`` is such
    noise: any part of the shape thicker than ``2 max_radius`` has a ball at
    least that large in its skeleton.

    Parameters
    ----------
    kept : bool ndarray
        Kept skeleton voxels.
    adjacency : (indptr, indices)
        26-adjacency of the skeleton voxels (`skeleton_adjacency`).
    radius : float ndarray
        D at the skeleton voxels.
    max_radius : float
        In voxels.

    Returns
    -------
    bool ndarray, aligned with ``kept``
        The kept voxels to prune.
    """
    indptr, indices = adjacency
    n = len(kept)
    rows = np.repeat(np.arange(n, dtype=np.int32), np.diff(indptr))
    both = kept[rows] & kept[indices]
    graph = csr_matrix((np.ones(int(both.sum()), dtype=np.int8), (rows[both], indices[both])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    label = np.where(kept, label, -1)
    largest = np.zeros(label.max() + 2, dtype=np.float64)
    np.maximum.at(largest, label + 1, radius)
    return kept & (largest[label + 1] < max_radius)
