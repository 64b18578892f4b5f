"""Which skeleton voxels are kept: the saliency rule (§3.1), the connectivity opening at the root
(eq. 2.3), the thin-part rule and the pruning of detached noise.

Flat arrays over the skeleton voxels, linked by their 26-adjacency (`saliency.skeleton_adjacency`).
"""

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

from skelfilter.core.neighbourhood import unravel


def saliency_measure(rho, radius):
    """Saliency ``sigma = rho / D`` (eq. 3.1), at the skeleton voxels.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §3.1, eq. 3.1.
    .. [2] A. Telea, "Feature preserving smoothing of shapes using saliency skeletons",
           Visualization in Medicine and Life Sciences II, Springer, 2012.
    """
    return (np.asarray(rho, dtype=np.float64) / np.maximum(np.asarray(radius, dtype=np.float64), 1e-12)).astype(
        np.float32)


def root_component(selected, adjacency, rho, radius=None, candidates=None):
    """The connectivity opening ``Gamma_y`` of the selected skeleton voxels at the root (eq. 2.3, 3.2, 4.4).

    The root ``y`` is the voxel of largest ``rho``, where the core skeleton is (§3.1.1). Two readings
    where the text is silent: the root is the largest ``rho`` among the *selected* voxels (at the
    global maximum of ``rho`` every step goes down, so with ``v = grad rho`` the derivative there is
    negative and the literal root would select nothing); and each connected component of the skeleton
    gets its own root, since the thesis defines the operator on a shape of one component and a shape of
    several would otherwise lose every body but one. Ties of ``rho`` (geodesic searches stop at a cap,
    `pruning_rules.search_cap`, so the whole core can share the largest value) go to the largest
    ``radius`` (``D``), the middle of the core, then to the first voxel. Where ``candidates`` is given,
    the root is among the selected candidates of a component if it has any: the pipeline leaves out the
    voxels whose feature points lie on different boundary components (a cavity the noise closed off,
    an object and the box's frame), whose infinite ``rho`` says which surfaces they separate, not
    that they are central.

    Returns
    -------
    bool ndarray, aligned with ``selected``
        The selected voxels 26-connected, through selected voxels, to a root.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §2.1.1 eq. 2.3, §3.1.1 eq. 3.2, §4.2 eq. 4.4.
    """
    selected = np.asarray(selected, dtype=bool)
    n = len(selected)
    if not selected.any():
        return selected.copy()
    indptr, indices = adjacency
    rows = np.repeat(np.arange(n, dtype=np.int32), np.diff(indptr))
    _, whole = connected_components(csr_matrix((np.ones(len(rows), dtype=np.int8), (rows, indices)), shape=(n, n)),
                                    directed=False)
    both = selected[rows] & selected[indices]
    graph = csr_matrix((np.ones(int(both.sum()), dtype=np.int8), (rows[both], indices[both])), shape=(n, n))
    _, part = connected_components(graph, directed=False)
    depth = np.zeros(n) if radius is None else -np.asarray(radius, dtype=np.float64)
    other = np.zeros(n, dtype=bool) if candidates is None else ~np.asarray(candidates, dtype=bool)
    chosen = np.flatnonzero(selected)
    order = chosen[np.lexsort((chosen, depth[chosen], -np.asarray(rho, dtype=np.float64)[chosen], other[chosen],
                               whole[chosen]))]
    first = np.ones(len(order), dtype=bool)
    first[1:] = whole[order[1:]] != whole[order[:-1]]
    rooted = np.zeros(part.max() + 1, dtype=bool)
    rooted[part[order[first]]] = True
    return selected & rooted[part]


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
    if n == 0:  # a shape too small for a skeleton (a cube of 2 or 4 voxels has none)
        return np.zeros(0, dtype=bool)
    rows = np.repeat(np.arange(n, dtype=np.int32), np.diff(indptr))
    both = kept[rows] & kept[indices]
    graph = csr_matrix((np.ones(int(both.sum()), dtype=np.int8), (rows[both], indices[both])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    label = np.where(kept, label, -1)
    largest = np.zeros(label.max() + 2, dtype=np.float64)
    np.maximum.at(largest, label + 1, radius)
    return kept & (largest[label + 1] < max_radius)
