"""The unified skeleton model (USM) of Jalba et al.: smoothed contraction, mass advection, max density.

Thesis §4.2.1 (eq. 4.8-4.10, the contraction direction as a velocity field) and §7.1.2-7.1.3
(eq. 7.8-7.11, the skeleton as the voxels mass accumulates in). On the grid:

* the contracting shape ``Y_t`` (eq. 4.9) is the level set ``D_s = t`` of the distance transform of
  the shape smoothed by a Gaussian of ``smoothing`` voxels (§7.1.3: "smoothing ... and then
  thresholding the result to create a smooth input volume");
* the contraction direction ``u = grad phi / |grad phi|`` (eq. 4.10) is ``grad D_s`` by central
  differences, which has unit length off the skeleton; on the skeleton, where fronts collide, the
  differences average the two sides' unit vectors, which is the momentum-conserving merge of the
  colliding mass (Jalba et al.): the normal components cancel and the mass moves on along the
  skeleton, slower, towards growing ``D_s``;
* eq. 7.8 is solved by the first-order upwind (donor-cell) finite-volume scheme, which conserves
  mass exactly, from unit mass on every boundary voxel of the smoothed shape; ``lambda`` is the
  largest density each voxel reaches (eq. 7.11).
"""

import numpy as np
from numba import prange
from scipy import ndimage

from skelfilter.core.distance import distance_transform, gradient_at
from skelfilter.core.neighbourhood import OFFSETS_6, bounding_box, flat_offsets
from skelfilter.runtime.compiled import njit

TIME_STEP = 0.5  # the donor-cell scheme is stable for dt * sum_k |u_k| <= 1, and sum_k |u_k| <= sqrt(3)
CROSSINGS = 2.0  # the advection runs for the time mass takes to cross the shape's box this many times


def smoothed_shape(volume, smoothing):
    """The set ``G_smoothing * X >= 1/2`` (§7.1.3), restricted to the volume's interior; X for 0."""
    volume = np.asarray(volume, dtype=bool)
    if smoothing <= 0:
        return volume.copy()
    smooth = ndimage.gaussian_filter(volume.astype(np.float32), smoothing, mode="constant") >= 0.5
    smooth[[0, -1], :, :] = smooth[:, [0, -1], :] = smooth[:, :, [0, -1]] = False
    return smooth


def contraction_direction(volume, smoothing, voxels):
    """USM velocity field ``u`` (eq. 4.10) at flat voxel indices.

    Parameters
    ----------
    volume : (nx, ny, nz) bool ndarray
        The set X; it must not touch the volume's faces.
    smoothing : float
        Standard deviation, in voxels, of the Gaussian the shape is smoothed with (0: none).
    voxels : int64 ndarray
        Flat indices to evaluate ``u`` at (not on the volume's faces).

    Returns
    -------
    u : (n, 3) float32 ndarray
        ``grad D_s`` by central differences: unit length off the skeleton of the smoothed shape,
        the mean of the colliding fronts' directions on it, 0 outside the smoothed shape.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §4.2.1, eq. 4.8-4.10.
    .. [2] A. C. Jalba, A. Sobiecki, A. C. Telea, "An unified multiscale framework for planar,
           surface, and curve skeletonization", IEEE TPAMI 38(1), 2016.
    """
    shape = smoothed_shape(volume, smoothing)
    if not shape.any():
        return np.zeros((len(voxels), 3), dtype=np.float32)
    distance = distance_transform(shape)
    return gradient_at(distance, np.asarray(voxels, dtype=np.int64))


def max_density(volume, smoothing=0.0, steps=None):
    """USM importance ``lambda(x) = max_t rho(x, t)`` (eq. 7.11) by mass advection (eq. 7.8).

    Parameters
    ----------
    volume : (nx, ny, nz) bool ndarray
        The set X; it must not touch the volume's faces.
    smoothing : float
        Gaussian smoothing of the shape in voxels (§7.1.3); the advection runs on the smoothed shape.
    steps : int, optional
        Time steps of ``TIME_STEP``; by default the time to cross the shape's bounding box
        ``CROSSINGS`` times at unit speed.

    Returns
    -------
    density : (nx, ny, nz) float32 ndarray
        ``lambda`` in units of one boundary voxel's mass; 0 outside the smoothed shape.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §7.1.2, eq. 7.8-7.11.
    .. [2] A. C. Jalba, A. Sobiecki, A. C. Telea, "An unified multiscale framework for planar,
           surface, and curve skeletonization", IEEE TPAMI 38(1), 2016.

    Examples
    --------
    >>> import numpy as np
    >>> box = np.zeros((20, 20, 20), bool); box[3:17, 3:17, 3:17] = True
    >>> density = max_density(box)
    >>> bool(density[10, 10, 10] > density[3, 10, 10])
    True
    """
    volume = np.asarray(volume, dtype=bool)
    shape = smoothed_shape(volume, smoothing)
    density = np.zeros(volume.shape, dtype=np.float32)
    inside = np.flatnonzero(shape.reshape(-1))
    if len(inside) == 0:
        return density
    distance = distance_transform(shape)
    u = gradient_at(distance, inside).astype(np.float64)
    lookup = np.full(shape.size, -1, dtype=np.int32)
    lookup[inside] = np.arange(len(inside), dtype=np.int32)
    neighbours = lookup[inside[:, None] + flat_offsets(shape.shape, OFFSETS_6)[None, :]]
    mass = (distance.reshape(-1)[inside] == 1).astype(np.float64)  # unit mass on the boundary
    if steps is None:
        extent = max(side.stop - side.start for side in bounding_box(shape))
        steps = int(np.ceil(CROSSINGS * extent / TIME_STEP))
    density.reshape(-1)[inside] = _advect(mass, u, neighbours, int(steps), TIME_STEP)
    return density


@njit(parallel=True)
def _advect(mass, u, neighbours, steps, dt):
    # Donor-cell fluxes: voxel i sends dt * |u_k| of its mass to its neighbour along sign(u_k) on
    # each axis k. A component that points out of the shape is dropped, so no mass is lost.
    n = len(mass)
    out = np.zeros((n, 6))  # fraction of the mass sent to neighbour slot s (OFFSETS_6 order)
    for i in prange(n):
        for k in range(3):
            s = 2 * k + 1 if u[i, k] > 0 else 2 * k
            if neighbours[i, s] >= 0:
                out[i, s] = dt * abs(u[i, k])
    stay = np.empty(n)
    for i in prange(n):
        stay[i] = 1.0 - out[i].sum()
    peak = mass.copy()
    current = mass.copy()
    following = np.empty(n)
    for _ in range(steps):
        for i in prange(n):
            m = current[i] * stay[i]
            for s in range(6):
                j = neighbours[i, s]
                if j >= 0:
                    m += current[j] * out[j, s ^ 1]  # j's slot pointing back at i is the opposite one
            following[i] = m
            if m > peak[i]:
                peak[i] = m
        current, following = following, current
    return peak.astype(np.float32)


def usm_skeleton(volume, smoothing=0.0, min_density=1.0, steps=None):
    """USM skeleton: the voxels of X whose max density exceeds ``min_density`` (§7.1.3).

    Mass arrives at a voxel off the skeleton once, as one front; where fronts collide it adds up.
    ``min_density = 1`` (one boundary voxel's mass) is the thesis' rule ``lambda(x) > 0`` counted above
    the front's own mass. The skeleton is not thin nor always centred (thesis Fig. 7.3): near curve
    skeletons converging fronts exceed it too.

    Returns
    -------
    skeleton : int64 ndarray
        Sorted flat indices.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §7.1.2-7.1.3.
    """
    density = max_density(volume, smoothing, steps)
    return np.flatnonzero(((density > min_density) & np.asarray(volume, dtype=bool)).reshape(-1))
