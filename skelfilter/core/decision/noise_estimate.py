"""How much noise at the skeleton's scale a shape carries, measured on what the pruning removes.

A stage of the pipeline prunes the skeleton of a set X (the shape for bumps, the background for
dents) and rebuilds K ⊆ X. What X loses, X \\ K, is noise, the shape's own features, or the skin of
its convex edges. The three differ in how high they stand above K (the distance to K, in voxels):

- a noise structure is low: however far overlapping bumps spread along the surface, each stands at
  most the noise height (the thesis' model: h + r, eq. 7.14) above the surface around it, and there
  are many of them, all over the surface;
- a feature (a leg, a wing, a fin, a rim) stands much higher, or is one of a few;
- an edge's skin stands a voxel or two.

So the estimate looks at the *peaks* of the height over X \\ K that rise at least `LEAST_DYNAMIC`
above the saddle joining them to a higher one (`prominent_peaks`; a plateau or a ridge whose voxel
wiggles rise less is one peak), at least `LEAST_PEAK` voxels high and at most `HIGHEST_NOISE` of the
model's size, and at how much of the surface they are spread over: the share of surface cells (cubes
of `CELL` of the size) holding a peak's top. Noise is found where that share reaches `LEAST_COVERAGE`;
its height is the `HEIGHT_QUANTILE` quantile of the peaks' heights.

Clean shapes cover at most 0.036 of their cells, well under `LEAST_COVERAGE`; what it was measured on,
and the peaks it replaced, are in ``docs/design/noise-estimate.md``.
"""

from dataclasses import dataclass

import numpy as np
from numba import prange

from skelfilter.core.distance import distance_transform
from skelfilter.core.neighbourhood import bounding_box
from skelfilter.runtime.compiled import njit

LEAST_PEAK = 3.0  # voxels: lower peaks are skins and relief (the clean shapes' peaks are mostly 2-3)
HIGHEST_NOISE = 0.075  # of the size: taller peaks are features whatever the estimate (12 voxels at 160)
CELL = 1.0 / 20.0  # of the size: the side of the cells over which the coverage is counted
LEAST_COVERAGE = 0.05  # share of surface cells with a peak from which noise is found
LEAST_DYNAMIC = 1.0  # voxels: a peak rises this much above its saddle to a higher one (the EDT's step)
HEIGHT_QUANTILE = 99.0


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
    height = distance_transform(far)
    del far
    height *= part[box]  # 0 outside part (distances are >= 0), without a whole-box temporary
    return box, height


def surface_cells(volume, cell):
    """Number of cells (cubes of side ``cell`` voxels from the grid's corner) holding a voxel of
    `neighbourhood.surface_voxels` of ``volume``.

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


def prominent_peaks(height, least_dynamic, overwrite=False):
    """The tops of the peaks of ``height`` (> 0; 0 is the floor) that rise at least ``least_dynamic``
    above the highest saddle joining them to a higher peak (their *dynamic*), 26-connected.

    One sweep from the highest voxel down joins voxels into peaks with a union-find: where two peaks
    meet at a voxel of height v, the lower one ends with dynamic = its top - v (the younger, on equal
    tops); a peak that meets none ends on the floor, with dynamic = its top. A plateau, or a ridge
    whose voxel-sized wiggles rise less than ``least_dynamic``, is one peak. n log n (the sort).

    ``overwrite``: ``height`` (float32, C-contiguous) may be overwritten, its memory holding the
    voxels' ranks (a whole grid less: what sets the pipeline's peak memory).

    Returns
    -------
    (int ndarray (n, 3), float32 ndarray (n,))
        The peaks' top voxels (the first in C order on a flat top) and their heights.

    References
    ----------
    .. [1] M. Grimaud, "New measure of contrast: the dynamics", Proc. SPIE 1769, Image Algebra and
           Morphological Image Processing III, 1992 (the dynamic of a regional maximum).

    Examples
    --------
    >>> import numpy as np
    >>> h = np.zeros((1, 1, 7), np.float32); h[0, 0] = [0, 4, 3.5, 5, 1, 3, 0]
    >>> tops, heights = prominent_peaks(h, 1.0)
    >>> [int(t[2]) for t in tops], [float(x) for x in heights]
    ([5, 3], [3.0, 5.0])
    """
    given = height
    height = np.ascontiguousarray(height, dtype=np.float32)
    flat = height.ravel()
    voxels = np.flatnonzero(flat > 0)
    order = voxels[np.argsort(-flat[voxels], kind="stable")]
    heights = flat[order]
    index = np.int32 if len(order) <= np.iinfo(np.int32).max else np.int64
    if overwrite and height is given and index is np.int32:
        rank = flat.view(np.int32)
        rank.fill(-1)
    else:
        rank = np.full(flat.size, -1, dtype=index)
    rank[order] = np.arange(len(order), dtype=index)
    ends = np.empty(len(order), dtype=index)
    count = _sweep(height.shape, order, heights, rank, np.float32(least_dynamic), ends)
    tops = order[ends[:count]]
    return np.column_stack(np.unravel_index(tops, height.shape)), heights[ends[:count]]


@njit()
def _root(parent, i):
    root = i
    while parent[root] != root:
        root = parent[root]
    while parent[i] != root:
        parent[i], i = root, parent[i]
    return root


@njit()
def _sweep(shape, order, heights, rank, least_dynamic, ends):
    # Voxels by rank (highest first, ``heights`` in that order); a peak's root's rank is its top's, so
    # the older peak (higher, or first on equal tops) has the smaller root. ``ends`` gets the top ranks
    # of the peaks kept.
    nx, ny, nz = shape
    parent = np.arange(len(order), dtype=rank.dtype)
    count = 0
    for r in range(len(order)):
        v = order[r]
        i, j, k = v // (ny * nz), (v // nz) % ny, v % nz
        for a in range(max(i - 1, 0), min(i + 2, nx)):
            for b in range(max(j - 1, 0), min(j + 2, ny)):
                for c in range(max(k - 1, 0), min(k + 2, nz)):
                    u = rank[(a * ny + b) * nz + c]
                    if u < 0 or u >= r:
                        continue
                    ru, rv = _root(parent, u), _root(parent, r)
                    if ru == rv:
                        continue
                    old, young = min(ru, rv), max(ru, rv)
                    if heights[young] - heights[r] >= least_dynamic:
                        ends[count] = young
                        count += 1
                    parent[young] = old
    for r in range(len(order)):
        if parent[r] == r and heights[r] >= least_dynamic:
            ends[count] = r
            count += 1
    return count


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
    removed = np.greater(stage_set, pruned)  # stage_set & ~pruned, without the temporary
    surface = surface_cells(stage_set, cell)
    box, height = height_above(removed, pruned, highest + 1)
    if box is None or surface == 0:
        return NoiseEstimate(side, False, 0.0, 0.0, 0)
    tops, heights = prominent_peaks(height, LEAST_DYNAMIC, overwrite=True)
    del height
    noise = (heights >= LEAST_PEAK) & (heights <= highest)
    tops, heights = tops[noise], heights[noise]
    coverage = len(_cells(tops, box, cell)) / surface
    if coverage < LEAST_COVERAGE:
        return NoiseEstimate(side, False, 0.0, float(coverage), len(heights))
    return NoiseEstimate(side, True, float(np.percentile(heights, HEIGHT_QUANTILE)), float(coverage), len(heights))
