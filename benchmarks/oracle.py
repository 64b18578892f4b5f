"""The per-ball oracle: the output of a skeleton pipeline that knew, ball by ball, which balls are noise
(the clean shape decides): the ceiling of a per-ball decision, which the quality benchmark reports
beside skelfilter's variants (``python -m benchmarks.quality --oracle``).

- `oracle`: the foreground balls whose centre lies inside the clean shape, their radii capped at the
  clean distance, united with the noisy shape's background voxels that no such background ball
  (centre outside the clean shape, radius capped likewise) covers. No stage order, one formulation for
  bumps and dents.
- `owned_oracle`: each voxel decided by the ball that owns it (the ball tangent at its nearest boundary
  point, `ray_owners`): the noisy shape less the voxels owned by foreground balls centred outside the
  clean shape, plus the background voxels owned by background balls centred inside it. No radius is
  capped and no voxel that no dropped ball owns changes, so it has no coverage gaps.
- `seam_smoothed`: the voxels a decision changed, and one voxel around them, take the value of the
  output smoothed by a Gaussian of `SEAM_SIGMA` (the level 1/2); every other voxel stays. The one-voxel
  tunnels and rims that a per-voxel decision leaves where a dropped ball meets a kept one close, so
  the output's genus can equal the clean shape's.

The experiments that measure what a pipeline's measures tell of the oracle's labels are in
``experiments/ball_oracle.py``.
"""

import numpy as np
from numba import njit, prange
from scipy import ndimage

from skelfilter.core import skeleton
from skelfilter.core.distance import distance_and_features
from skelfilter.core.reconstruct import union_of_balls

PROTRUSION = 1.0  # voxels a ball may stand beyond the clean shape and still be labelled keep
# Voxels: the seam smoothing's Gaussian, chosen on the tuning shapes (sigma 0.7 keeps a little more
# of the thin parts and leaves more handles: genus equal to the clean shape's on 16 of 24 against 19).
SEAM_SIGMA = 1.0
SEAM_GROW = 1  # voxels around the changed ones that the seam smoothing may change too


def bounded_background(mask):
    """The complement of ``mask`` without the grid's outer layer (it stands for the infinite outside)."""
    background = ~mask
    background[[0, -1], :, :] = background[:, [0, -1], :] = background[:, :, [0, -1]] = False
    return background


def labelled_balls(noisy_side, clean_side):
    """The IE-skeleton balls of ``noisy_side``: (flat centres, radii, clean radii, noise labels)."""
    distance, _ = distance_and_features(noisy_side)
    centres = skeleton.ie_skeleton(distance)
    radii = distance.reshape(-1)[centres].astype(np.float64)
    clean_distance = ndimage.distance_transform_edt(clean_side).reshape(-1)[centres]
    return centres, radii, clean_distance, radii - clean_distance > PROTRUSION


def oracle(noisy, clean):
    """The oracle's output mask (see the module's docstring) and the foreground's labelled balls."""
    shape = noisy.shape
    fg = labelled_balls(noisy, clean)
    bg = labelled_balls(bounded_background(noisy), bounded_background(clean))

    def kept_union(centres, radii, clean_radii):
        inside = clean_radii > 0  # the centre lies in the clean set of its side
        if not inside.any():
            return np.zeros(shape, dtype=bool)
        return union_of_balls(shape, centres[inside], np.minimum(radii, clean_radii)[inside])[0]

    out = kept_union(*fg[:3]) | (~noisy & ~kept_union(*bg[:3]))
    out[[0, -1], :, :] = out[:, [0, -1], :] = out[:, :, [0, -1]] = False
    return out, fg


RAY_TOLERANCE = 1.0  # voxels: how far past the nearest boundary point's ball a ray may go (`ray_owners`)


def ray_owners(side):
    """The skeleton ball that owns each voxel of the set ``side``: the ball tangent at the voxel's
    nearest boundary point, found by walking from that point through the voxel, voxel by voxel, while
    the point stays the nearest (to within `RAY_TOLERANCE`); the walk ends at the ball's centre, and the
    owner is the IE-skeleton voxel within one voxel of where it ends whose ball comes nearest to
    touching that boundary point (``| |s - f| - D(s) |`` least).

    Returns (flat voxels, owner: index into the centres or -1 where none lies there, centres, radii).
    """
    distance, features = distance_and_features(side)
    centres = skeleton.ie_skeleton(distance)
    index = np.full(side.size, -1, dtype=np.int64)
    index[centres] = np.arange(len(centres))
    voxels = np.flatnonzero(side)
    owner = _ray_owners(voxels, distance.reshape(-1), features.reshape(-1), index, side.shape, RAY_TOLERANCE)
    return voxels, owner, centres, distance.reshape(-1)[centres].astype(np.float64)


@njit(parallel=True, cache=True)
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


def owned_output(noisy, fg_owners, bg_owners, fg_dropped, bg_dropped):
    """The noisy shape less its voxels owned by a dropped foreground ball, plus its background voxels
    owned by a dropped background ball (`ray_owners`; ``*_dropped``: a bool per ball). Every voxel
    no dropped ball owns stays as it is: no coverage gaps."""
    out = noisy.copy().reshape(-1)
    for (voxels, owner, _, _), dropped, value in ((fg_owners, fg_dropped, False), (bg_owners, bg_dropped, True)):
        hit = (owner >= 0) & dropped[np.maximum(owner, 0)]
        out[voxels[hit]] = value
    out = out.reshape(noisy.shape)
    out[[0, -1], :, :] = out[:, [0, -1], :] = out[:, :, [0, -1]] = False
    return out


def owned_oracle(noisy, clean):
    """`owned_output` with the oracle's drops: the balls centred outside the clean shape (its
    complement's, for the background)."""
    fg, bg = ray_owners(noisy), ray_owners(bounded_background(noisy))
    clean_fg = ndimage.distance_transform_edt(clean).reshape(-1)
    clean_bg = ndimage.distance_transform_edt(bounded_background(clean)).reshape(-1)
    return owned_output(noisy, fg, bg, clean_fg[fg[2]] <= 0, clean_bg[bg[2]] <= 0)


def seam_smoothed(noisy, out, sigma=SEAM_SIGMA, grow=SEAM_GROW):
    """``out`` where the voxels it changed from ``noisy``, grown by ``grow``, take the value of ``out``
    smoothed by a Gaussian of ``sigma`` voxels (at least 1/2 is inside); every other voxel as ``out``
    has it (so a shape ``out`` leaves unchanged stays unchanged)."""
    seam = ndimage.binary_dilation(noisy ^ out, iterations=grow)
    smooth = ndimage.gaussian_filter(out.astype(np.float32), sigma) >= 0.5
    result = out.copy()
    result[seam] = smooth[seam]
    return result
