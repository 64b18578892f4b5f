"""How much noise at the skeleton's scale a shape carries, measured on what the pruning removes.

A stage of the pipeline prunes the skeleton of a set X (the shape for bumps, the background for
dents) and rebuilds K ⊆ X. What X loses, X \\ K, is noise, the shape's own features, or the skin of
its convex edges. The three differ in how high they stand above K (the distance to K, in voxels):

- a noise structure is low: however far overlapping bumps spread along the surface, each stands at
  most the noise height (the thesis' model: h + r, eq. 7.14) above the surface around it, and there
  are many of them, all over the surface;
- a feature (a leg, a wing, a fin, a rim) stands much higher, or is one of a few;
- an edge's skin stands a voxel or two.

So the estimate looks at the *peaks* of the height over X \\ K (local maxima over a 5³ window, at
least `LEAST_PEAK` voxels high and at most `HIGHEST_NOISE` of the model's size) and at how much of
the surface they are spread over: the share of surface cells (cubes of `CELL` of the size) holding a
peak, a plateau of peaks longer than `RIDGE` counted in one cell only (a feature's ridge,
pruned along its length, is one plateau however many cells it crosses: a chair's slats at 128 voxels
covered 10 % of the cells counted voxel by voxel). Noise is found where that share reaches
`LEAST_COVERAGE`; its height is the `HEIGHT_QUANTILE`
quantile of the peaks' heights.

Chosen on the tuning shapes of ``benchmarks/quality.py`` at resolution 160 after a pruning at
t = 0.1875 of the size: clean shapes cover at most 0.05 of their cells (a heat sink's fins, a mug's
rim), the thesis' noise at least 0.13 (sparse stripes on a chair) and mostly 0.15-0.5; the heights
found are 6-8 voxels for h = 3 (the bumps stand h + r = 5.1 above the clean surface, which the
pruning lowers by a voxel or two) and 10-11 for h = 7. See ``docs/noise-estimate.md``.
"""

from dataclasses import dataclass

import numpy as np
from numba import prange
from scipy import ndimage

from skelfilter.core.distance import distance_and_features
from skelfilter.core.neighbourhood import bounding_box
from skelfilter.runtime.compiled import njit

LEAST_PEAK = 3.0  # voxels: lower peaks are skins and relief (the clean shapes' peaks are mostly 2-3)
HIGHEST_NOISE = 0.075  # of the size: taller peaks are features whatever the estimate (12 voxels at 160)
CELL = 1.0 / 20.0  # of the size: the side of the cells over which the coverage is counted
LEAST_COVERAGE = 0.08  # share of surface cells with a peak from which noise is found
HEIGHT_QUANTILE = 99.0
PEAK_WINDOW = 5  # voxels: the side of the window in which a peak is the highest
RIDGE = 2 * PEAK_WINDOW  # voxels: a plateau of peaks longer than this is a ridge (counted in one cell)


@dataclass(frozen=True)
class NoiseEstimate:
    """What `estimate_noise` found on one side of the surface.

    Attributes
    ----------
    side : str
        ``"bumps"`` (the shape's stage) or ``"dents"`` (the background's).
    found : bool
        Noise at the skeleton's scale was found (coverage >= `LEAST_COVERAGE`).
    height : float
        Voxels: the `HEIGHT_QUANTILE` quantile of the peaks' heights (0 when nothing was found).
    coverage : float
        Share of the surface cells that hold a peak.
    peaks : int
        Peaks counted.
    """

    side: str
    found: bool
    height: float
    coverage: float
    peaks: int

    def describe(self):
        """One line a user can read, e.g. ``bumps up to 6.2 voxels high on 38 % of the surface``."""
        if not self.found:
            return f"{self.side}: none found ({100 * self.coverage:.0f} % of the surface has peaks, " \
                   f"from {100 * LEAST_COVERAGE:.0f} % it is noise)"
        return f"{self.side} up to {self.height:.1f} voxels high on {100 * self.coverage:.0f} % of the surface"


def height_above(part, base, reach):
    """Distance (voxels, float32) from each voxel of ``part`` to the nearest voxel of ``base``, up to ``reach``.

    Computed in the box of ``part`` widened by ``reach``: farther ``base`` voxels cannot bring a
    distance under ``reach``, so the values are exact up to it and at least ``reach`` beyond.

    Returns
    -------
    (slices, float32 ndarray)
        The box, and the distances over it (0 outside ``part``); ``(None, None)`` for an empty part.
    """
    box = bounding_box(part, margin=int(np.ceil(reach)) + 1)
    if box is None:
        return None, None
    far = ~base[box]
    if far.all():  # no base in reach: every voxel is far
        return box, np.where(part[box], np.float32(reach), np.float32(0))
    height = distance_and_features(far)[0]
    height[~part[box]] = 0.0
    return box, height


def surface_voxels(volume):
    """The set voxels with an unset 6-neighbour."""
    return volume & ~ndimage.binary_erosion(volume)


def surface_cells(volume, cell):
    """Number of cells (cubes of side ``cell`` voxels from the grid's corner) holding a voxel of
    `surface_voxels` of ``volume``.

    Examples
    --------
    >>> import numpy as np
    >>> cube = np.zeros((8, 8, 8), bool); cube[1:7, 1:7, 1:7] = True
    >>> int(surface_cells(cube, 4))
    8
    """
    volume = np.ascontiguousarray(volume, dtype=bool)
    held = np.zeros(tuple(-(-n // cell) for n in volume.shape), dtype=bool)
    _mark_surface_cells(volume, cell, held)
    return int(np.count_nonzero(held))


@njit(parallel=True)
def _mark_surface_cells(x, cell, held):
    # The planes of one row of cells run in one thread: no two threads write the same cell.
    nx, ny, nz = x.shape
    for ci in prange(held.shape[0]):
        for i in range(ci * cell, min((ci + 1) * cell, nx)):
            for j in range(ny):
                for k in range(nz):
                    if x[i, j, k] and (i == 0 or i == nx - 1 or j == 0 or j == ny - 1 or k == 0 or k == nz - 1
                                       or not (x[i - 1, j, k] and x[i + 1, j, k] and x[i, j - 1, k]
                                               and x[i, j + 1, k] and x[i, j, k - 1] and x[i, j, k + 1])):
                        held[ci, j // cell, k // cell] = True


def local_peaks(height, least, highest, window):
    """Voxels whose ``height`` lies in [least, highest] and is the largest of the ``window``-sided cube
    around them (clipped to the array): ``maximum_filter(height, window) <= height`` there, scipy's
    reflected border giving the same maximum.

    Examples
    --------
    >>> import numpy as np
    >>> h = np.zeros((5, 5, 5), np.float32); h[2, 2, 2] = 4; h[2, 2, 3] = 3
    >>> [tuple(int(i) for i in p) for p in np.argwhere(local_peaks(h, 3.0, 9.0, 3))]
    [(2, 2, 2)]
    """
    out = np.zeros(height.shape, dtype=bool)
    _local_peaks(np.ascontiguousarray(height), np.float32(least), np.float32(highest), window // 2, out)
    return out


@njit(parallel=True)
def _local_peaks(h, least, highest, reach, out):
    nx, ny, nz = h.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                v = h[i, j, k]
                if v < least or v > highest:
                    continue
                top = True
                for a in range(max(i - reach, 0), min(i + reach + 1, nx)):
                    for b in range(max(j - reach, 0), min(j + reach + 1, ny)):
                        for c in range(max(k - reach, 0), min(k + reach + 1, nz)):
                            if h[a, b, c] > v:
                                top = False
                out[i, j, k] = top


def _cells(coords, box, cell):
    """Distinct cells (cubes of side ``cell`` voxels on the full grid) holding one of the voxels
    ``coords`` (an (n, 3) array of indices into ``box``)."""
    coords = (coords + np.array([s.start for s in box])) // cell
    return np.unique((coords[:, 0] * 65536 + coords[:, 1]) * 65536 + coords[:, 2])


def estimate_noise(stage_set, pruned, resolution, side="bumps"):
    """Estimate the noise of one side of a surface from what a pruning removed.

    Parameters
    ----------
    stage_set : bool ndarray
        The set X whose skeleton was pruned (the shape, or the background for dents).
    pruned : bool ndarray
        Its reconstruction K ⊆ X after pruning.
    resolution : int
        Voxels along the model's longest side (sets `HIGHEST_NOISE` and `CELL` in voxels).
    side : str
        ``"bumps"`` or ``"dents"``, for the description.

    Returns
    -------
    NoiseEstimate

    Examples
    --------
    >>> import numpy as np
    >>> cube = np.zeros((40, 40, 40), bool); cube[8:32, 8:32, 8:32] = True
    >>> estimate_noise(cube, cube, 24).found
    False
    """
    highest = HIGHEST_NOISE * resolution
    cell = max(2, int(round(CELL * resolution)))
    removed = stage_set & ~pruned
    surface = surface_cells(stage_set, cell)
    box, height = height_above(removed, pruned, highest + 1)
    if box is None or surface == 0:
        return NoiseEstimate(side, False, 0.0, 0.0, 0)
    peaks = local_peaks(height, LEAST_PEAK, highest, PEAK_WINDOW)
    labels, count = ndimage.label(peaks, structure=np.ones((3, 3, 3), dtype=bool))
    # A plateau of peaks longer than RIDGE is a feature's ridge (a slat, a rim pruned along
    # its length): it counts in one cell, its first voxel's, however many cells it crosses.
    coords = np.argwhere(peaks)
    plateau = labels[peaks]  # in the order of coords (both C order)
    _, first = np.unique(plateau, return_index=True)
    extent = np.array([max(s.stop - s.start for s in b) for b in ndimage.find_objects(labels)])
    counted = extent[plateau - 1] <= RIDGE
    counted[first] = True
    coverage = len(_cells(coords[counted], box, cell)) / surface if count else 0.0
    if coverage < LEAST_COVERAGE:
        return NoiseEstimate(side, False, 0.0, float(coverage), int(count))
    # The highest voxel of each plateau (on the peak voxels only: no sort of the whole box).
    heights = np.zeros(count + 1, dtype=np.float32)
    np.maximum.at(heights, plateau, height[peaks])
    heights = heights[1:]
    return NoiseEstimate(side, True, float(np.percentile(heights, HEIGHT_QUANTILE)), float(coverage), int(count))
