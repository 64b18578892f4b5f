"""Which skeleton ball owns each voxel, and a decision made ball by ball carried out on the voxels.

A set is the union of its skeleton's balls (§2.3); a voxel lies in many of them, but one ball is
tangent to the surface at the voxel's nearest boundary point: the ball whose centre the voxel's
distance gradient leads to. Deciding a ball then decides the voxels it owns (`owned_output`), with no
gaps where two balls overlap, and `seam_smoothed` takes off the one-voxel threads and rims such a
per-voxel decision leaves where a dropped ball meets a kept one.

Used by the two-sided decision (`skelfilter.core.decision.two_sided`) and by the quality benchmark's
per-ball oracle (``benchmarks/oracle.py``).
"""

import numpy as np
from numba import prange
from scipy import ndimage

from skelfilter.core import skeleton
from skelfilter.core.distance import distance_and_features
from skelfilter.core.neighbourhood import dilated_by_cross
from skelfilter.runtime.compiled import njit

RAY_TOLERANCE = 1.0  # voxels: how far past the nearest boundary point's ball a ray may go (`ray_owners`)
# Voxels: the seam smoothing's Gaussian (sigma 0.7 keeps a little more of the thin parts and leaves more
# handles: on the per-ball oracle, genus equal to the clean shape's on 16 of 24 tuning cases against 19).
SEAM_SIGMA = 1.0
SEAM_GROW = 1  # voxels around the changed ones that the seam smoothing may change too


def bounded_background(mask):
    """The complement of ``mask`` without the grid's outer layer (it stands for the infinite outside)."""
    background = ~mask
    background[[0, -1], :, :] = background[:, [0, -1], :] = background[:, :, [0, -1]] = False
    return background


def ray_owners(side, reach=None):
    """The IE-skeleton ball (eq. 7.7) that owns each voxel of the set ``side``: the ball tangent at the
    voxel's nearest boundary point, found by walking from that point through the voxel, voxel by voxel,
    while the point stays the nearest (to within `RAY_TOLERANCE`); the walk ends at the ball's centre,
    and the owner is the skeleton voxel within one voxel of where it ends whose ball comes nearest to
    touching that boundary point (``| |s - f| - D(s) |`` least).

    Parameters
    ----------
    side : bool ndarray
        The set; it must not touch the grid's faces.
    reach : float, optional
        Voxels: only the voxels of ``side`` this close to its boundary are looked at (default: all).

    Returns
    -------
    voxels : int64 ndarray
        The flat voxels.
    owner : int64 ndarray
        Per voxel, the index of its ball into ``centres``; -1 where no skeleton voxel lies there.
    centres : int64 ndarray
        The skeleton's flat voxels.
    radii : float64 ndarray
        Their balls' radii (voxels).
    """
    distance, features = distance_and_features(side)
    centres = skeleton.ie_skeleton(distance)
    index = np.full(side.size, -1, dtype=np.int64)
    index[centres] = np.arange(len(centres))
    voxels = np.flatnonzero(side if reach is None else side & (distance <= reach))
    owner = _ray_owners(voxels, distance.reshape(-1), features.reshape(-1), index, side.shape, RAY_TOLERANCE)
    return voxels, owner, centres, distance.reshape(-1)[centres].astype(np.float64)


@njit(parallel=True)
def _ray_owners(voxels, distance, features, index, shape, tolerance):
    nx, ny, nz = shape
    out = np.full(voxels.size, -1, dtype=np.int64)
    for k in prange(voxels.size):
        v = voxels[k]
        x, y, z = v // (ny * nz), (v // nz) % ny, v % nz
        f = features[v]
        fx, fy, fz = f // (ny * nz), (f // nz) % ny, f % nz
        length = np.sqrt((x - fx) ** 2 + (y - fy) ** 2 + (z - fz) ** 2)
        ux, uy, uz = (x - fx) / length, (y - fy) / length, (z - fz) / length
        ex, ey, ez = x, y, z
        step = 1.0
        while True:
            px, py, pz = int(np.rint(x + step * ux)), int(np.rint(y + step * uy)), int(np.rint(z + step * uz))
            if not (0 <= px < nx and 0 <= py < ny and 0 <= pz < nz):
                break
            d = distance[(px * ny + py) * nz + pz]
            if d <= 0 or np.sqrt((px - fx) ** 2 + (py - fy) ** 2 + (pz - fz) ** 2) - d > tolerance:
                break
            ex, ey, ez = px, py, pz
            step += 1.0
        best, best_gap = -1, np.inf
        for i in range(max(ex - 1, 0), min(ex + 2, nx)):
            for j in range(max(ey - 1, 0), min(ey + 2, ny)):
                for m in range(max(ez - 1, 0), min(ez + 2, nz)):
                    q = (i * ny + j) * nz + m
                    if index[q] < 0:
                        continue
                    gap = abs(np.sqrt((i - fx) ** 2 + (j - fy) ** 2 + (m - fz) ** 2) - distance[q])
                    if gap < best_gap:
                        best, best_gap = index[q], gap
        out[k] = best
    return out


def owned_output(volume, fg_owners, bg_owners, fg_dropped, bg_dropped):
    """``volume`` less its voxels owned by a dropped foreground ball, plus its background voxels owned by
    a dropped background ball (``*_owners``: `ray_owners` of each side; ``*_dropped``: a bool per
    ball). Every voxel no dropped ball owns stays as it is: no coverage gaps."""
    out = volume.copy().reshape(-1)
    for (voxels, owner, _, _), dropped, value in ((fg_owners, fg_dropped, False), (bg_owners, bg_dropped, True)):
        hit = (owner >= 0) & dropped[np.maximum(owner, 0)]
        out[voxels[hit]] = value
    out = out.reshape(volume.shape)
    out[[0, -1], :, :] = out[:, [0, -1], :] = out[:, :, [0, -1]] = False
    return out


def seam_smoothed(volume, out, sigma=SEAM_SIGMA, grow=SEAM_GROW):
    """``out`` where the voxels it changed from ``volume``, grown by ``grow``, take the value of ``out``
    smoothed by a Gaussian of ``sigma`` voxels (at least 1/2 is inside); every other voxel as ``out``
    has it (so a shape ``out`` leaves unchanged stays unchanged)."""
    seam = dilated_by_cross(volume ^ out, grow)
    smooth = ndimage.gaussian_filter(out.astype(np.float32), sigma) >= 0.5
    result = out.copy()
    result[seam] = smooth[seam]
    return result
