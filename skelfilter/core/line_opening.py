"""Opening by line segments: the voxels of a set that a straight run of voxels inside it passes through.

The union over directions of the openings by a segment of ``length`` voxels (directional morphological
filtering, Soille & Talbot 2001) keeps whatever is long in some direction: a leg, a slat, a wing, a
rim, and the tip of a part that stands on a deep body; a blob of noise on a thin part, no longer than
the segment in any direction, goes. Along each direction the opening is the runs of the set at least
``length`` voxels long, found in one pass over the grid.
"""

import numpy as np
from numba import prange

from skelfilter.core.neighbourhood import OFFSETS_26
from skelfilter.runtime.compiled import njit

# The 13 directions of the 26-neighbourhood, one of each opposite pair (the offsets are listed in
# lexicographic order, so the second half is the negation of the first): axes, face and body diagonals.
DIRECTIONS = OFFSETS_26[len(OFFSETS_26) // 2:]


def line_opening(volume, length, directions=DIRECTIONS):
    """The voxels of ``volume`` that lie on a run of at least ``length`` voxels of ``volume`` along one
    of ``directions``.

    A run along direction ``d`` is a digital line ``v, v + d, v + 2d, ...`` of set voxels; the grid's
    outside counts as unset. Per direction this is the opening by the segment of ``length`` voxels
    along ``d``, and the result is the union of these openings [1]_.

    Parameters
    ----------
    volume : (nx, ny, nz) ndarray of bool
    length : int
        Voxels (steps along ``d``, each 1, √2 or √3 long) a run must reach; at least 1.
    directions : (n, 3) ndarray of int, optional
        Steps with components in {-1, 0, 1}; default the 13 directions of the 26-neighbourhood.

    Returns
    -------
    (nx, ny, nz) ndarray of bool

    References
    ----------
    .. [1] P. Soille, H. Talbot, "Directional morphological filtering", IEEE Transactions on Pattern
           Analysis and Machine Intelligence 23(11), 2001, pp. 1313-1329.

    Examples
    --------
    >>> import numpy as np
    >>> rod = np.zeros((5, 5, 30), bool); rod[2, 2, 2:27] = True     # 25 voxels long
    >>> rod[1:4, 1:4, 10] = True                                      # a 3-voxel collar on it
    >>> int(line_opening(rod, 20).sum())
    25
    """
    volume = np.ascontiguousarray(volume, dtype=bool)
    length = int(length)
    if length < 1:
        raise ValueError(f"length must be at least 1 voxel, got {length}")
    directions = np.asarray(directions, dtype=np.int64).reshape(-1, 3)
    if np.any(np.abs(directions) > 1) or not np.all(np.any(directions != 0, axis=1)):
        raise ValueError("directions must be non-zero steps with components in {-1, 0, 1}")
    out = np.zeros(volume.shape, dtype=bool)
    for d in directions:
        _long_runs(volume, out, d[0], d[1], d[2], length)
    return out


@njit(parallel=True)
def _long_runs(volume, out, dx, dy, dz, length):
    """Mark in ``out`` the voxels of runs of ``volume`` along (dx, dy, dz) at least ``length`` long:
    each run is walked from its first voxel (the one whose predecessor is unset or off the grid). The
    runs along one direction are disjoint, so the planes their first voxels lie in are shared among
    the threads: no voxel is written by two."""
    nx, ny, nz = volume.shape
    for plane in prange(nx):
        x = np.int64(plane)  # prange's index may be unsigned: the steps back need a signed one
        for y in range(ny):
            for z in range(nz):
                if not volume[x, y, z]:
                    continue
                px, py, pz = x - dx, y - dy, z - dz
                if 0 <= px < nx and 0 <= py < ny and 0 <= pz < nz and volume[px, py, pz]:
                    continue
                n = 0
                cx, cy, cz = x, y, z
                while 0 <= cx < nx and 0 <= cy < ny and 0 <= cz < nz and volume[cx, cy, cz]:
                    n += 1
                    cx += dx
                    cy += dy
                    cz += dz
                if n < length:
                    continue
                cx, cy, cz = x, y, z
                for _ in range(n):
                    out[cx, cy, cz] = True
                    cx += dx
                    cy += dy
                    cz += dz
