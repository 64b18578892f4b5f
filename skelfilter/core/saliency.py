"""Pruning measures of the skeleton: the velocity fields (§4.2.1), the derivative measure (§4.2) and
the streamline importance rho+ (§5.2.1 and §5.2.2). `skelfilter.core.decision.selection` keeps voxels by them.

Everything here works on flat arrays over the skeleton voxels, linked by
their 26-adjacency; ``rho`` exists only on the skeleton, so its derivative
is taken from skeleton neighbours only (§4.2.1).
"""

import numba
import numpy as np

from skelfilter.core.distance import gradient_at
from skelfilter.core.neighbourhood import OFFSETS_26, flat_offsets, unravel
from skelfilter.runtime.compiled import njit

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


@njit(parallel=True)
def _neighbour_count(lookup, skeleton, steps):
    counts = np.zeros(skeleton.size, dtype=np.int64)
    for i in numba.prange(skeleton.size):
        for step in steps:
            counts[i] += lookup[skeleton[i] + step] >= 0
    return counts


@njit(parallel=True)
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


def importance_gradient_velocity(rho, skeleton, shape):
    """Velocity field ``v(x) = grad rho(x)`` (eq. 4.5), shape ``(n, 3)``.

    ``rho`` lives on the skeleton only, so each axis' difference is taken between skeleton voxels:
    central where both neighbours along the axis are on the skeleton, one-sided where one is, 0 where
    none is (the thesis' central differences over a ``rho`` of 0 off the skeleton would point every
    ``v`` into the skeleton, not along it).

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §4.2.1, eq. 4.5-4.6.
    """
    skeleton = np.asarray(skeleton, dtype=np.int64)
    rho = np.asarray(rho, dtype=np.float64)
    lookup = np.full(int(np.prod(shape)), -1, dtype=np.int32)
    lookup[skeleton] = np.arange(len(skeleton), dtype=np.int32)
    out = np.zeros((len(skeleton), 3), dtype=np.float32)
    for axis, step in enumerate(np.cumprod((1,) + tuple(shape[:0:-1]))[::-1]):
        ahead, behind = lookup[skeleton + step], lookup[skeleton - step]
        up = np.where(ahead >= 0, rho[ahead], rho)
        down = np.where(behind >= 0, rho[behind], rho)
        both = (ahead >= 0) & (behind >= 0)
        out[:, axis] = np.where(both, 0.5 * (up - down), up - down)
    return out


def derivative_measure(rho, distance, skeleton, velocity, adjacency, guard=0.1, min_cosine=STREAM_COSINE,
                       min_rho=0.0, max_rho=np.inf):
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
    max_rho : float
        Where the step starts or ends at this importance or above (the cap of the
        geodesic searches, which hides the rise of ``rho``) the measure is undefined.

    Returns
    -------
    sigma_bar : float32 ndarray
        NaN where ``D`` grows by less than ``guard`` per voxel along the step
        (eq. 4.3), where no skeleton neighbour lies ahead along ``v``, or where
        ``rho < min_rho`` or the step reaches ``max_rho``: there the measure is
        undefined and the voxel is never a ligature candidate.

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
                        guard, min_cosine, float(max_rho))
    sigma[rho < min_rho] = np.nan
    return sigma


@njit(parallel=True)
def _step_ratio(coords, rho, dist, velocity, indptr, indices, guard, min_cosine, max_rho):
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
        if rise < guard * best_len or rho[best_j] >= max_rho or rho[i] >= max_rho:  # eq. 4.3, the cap
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


@njit()
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


def direct_rho_plus(rho, sigma_bar, adjacency, velocity, skeleton, shape, k=0.9):
    """Importance ``rho+`` of the direct streamlines (eq. 5.1-5.3).

    The path of ``x`` steps from ``a_k`` to the 26-neighbour ``y`` on the skeleton that maximises
    ``v(a_k) . (y - a_k)`` among those with ``rho(y) >= rho(a_k)`` (eq. 5.1, ties to the first in
    `OFFSETS_26` order); it ends at a voxel with no such neighbour (a local root) or a low-derivative
    voxel (``sigma_bar <= k``; NaN, undefined, never is). ``rho+(x)`` is the largest ``rho`` on the path
    (eq. 5.2), that of its last voxel (eq. 5.3). Every voxel has one successor, so the paths form a
    forest and each voxel is resolved once; a path that comes back to a voxel (a cycle on a plateau of
    equal ``rho``) ends there with that ``rho``.

    Returns
    -------
    rho_plus : float32 ndarray
        ``rho_plus >= rho`` everywhere.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §5.2.1, eq. 5.1-5.3.
    """
    indptr, indices = adjacency
    rho = np.asarray(rho, dtype=np.float32)
    coords = unravel(skeleton, shape).astype(np.float64)
    ligature = np.asarray(sigma_bar <= k)  # NaN compares False
    successor = _successors(rho, ligature, indptr, indices, coords, np.asarray(velocity, dtype=np.float64))
    return _path_ends(rho, successor)


@njit(parallel=True)
def _successors(rho, ligature, indptr, indices, coords, velocity):
    n = rho.shape[0]
    out = np.full(n, -1, dtype=np.int64)
    for i in numba.prange(n):
        if ligature[i]:
            continue
        best = -np.inf
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            if rho[j] < rho[i]:
                continue
            along = (velocity[i, 0] * (coords[j, 0] - coords[i, 0]) + velocity[i, 1] * (coords[j, 1] - coords[i, 1])
                     + velocity[i, 2] * (coords[j, 2] - coords[i, 2]))  # eq. 5.1
            if along > best:
                best, out[i] = along, j
    return out


@njit()
def _path_ends(rho, successor):
    n = rho.shape[0]
    out = rho.copy()
    state = np.zeros(n, dtype=np.int8)  # 0 unseen, 1 on the path being followed, 2 resolved
    path = np.empty(n, dtype=np.int64)
    for start in range(n):
        if state[start]:
            continue
        length, i = 0, start
        while i >= 0 and state[i] == 0:
            state[i] = 1
            path[length] = i
            length += 1
            i = successor[i]
        if i < 0:
            value = rho[path[length - 1]]  # the path's end, eq. 5.3
        elif state[i] == 2:
            value = out[i]
        else:
            value = rho[i]  # back on the path: a plateau of equal rho
        for m in range(length):
            out[path[m]] = value
            state[path[m]] = 2
    return out
