"""The fine pass of a binary volume: noise of a voxel or three smoothed away, features kept by their extent.

A segmentation thresholded from a noisy image (CT, MRI) carries bumps, dents, islands and pits of
one to three voxels together, all over its surface: noise below the skeleton's scale, which the
pruning does not see. Smoothing removes it (a Gaussian of the mask, then a threshold at one half,
as in 3D Slicer's smoothing effects), but also rounds or removes whatever is as thin as the
smoothing is wide: a plate, a leg, a rim, a narrow gap.

The fine pass smooths at the widest scale where that is safe, voxel by voxel. It measures the noise
first (`voxel_roughness`: the share of the surface where the mask disagrees with its own light
smoothing; a clean voxel model, staircase and all, agrees nearly everywhere and passes through
unchanged). Small pieces and pockets go (`edt_filters.specks`). Then, from the widest Gaussian of
`LEVELS` to the narrowest (twiced and keeping the volume, `smoothed_volume_kept`, where the roughness
says voxels are flipped: `FLIPPED_ROUGHNESS`), a level decides every voxel it still may: wherever its smoothing removed
or added a part that stands higher above the smoothed surface than the noise
(`feature_restore.features_by_extent` on both sides, and the necks of parts it cut apart), that part
and `GROW` voxels around it are left to the next, narrower level; what even the narrowest level
would change there keeps the input's voxels. So a wide plate is smoothed at sigma 2 while a leg two
voxels thick keeps its own voxels, noise and all.

Chosen on the tuning shapes of ``benchmarks/volumes.py`` (segmentation-like noise of standard
deviation 0.6 and 1 voxel at resolution 128); see ``docs/design/noise-estimate.md``.
"""

from dataclasses import dataclass

import numpy as np

from skelfilter.core import edt_filters
from skelfilter.core.decision import feature_restore
from skelfilter.core.gaussian_filter import gaussian_filter  # scipy's (mode reflect), over the cores
from skelfilter.core.neighbourhood import bounding_box, dilated_by_cross, surface_voxels

LEVELS = (2.0, 1.5, 1.0, 0.6)  # voxels: the Gaussians' sigmas, widest first
MEASURE_SIGMA = 0.8  # voxels: the light smoothing the noise is measured against
# Share of the light smoothing's surface voxels where the mask disagrees, from which there is noise:
# clean voxel models measure at most 0.020 (a four-legged animal), noise of standard deviation 0.3
# voxels 0.019-0.037, 0.6 voxels 0.045-0.084, 1 voxel 0.080-0.107.
LEAST_ROUGHNESS = 0.035
# The same share against the light smoothing made shrink-free (twicing: ``2 G m - G G m``), from which
# the roughness of a thick-sliced mask on its own grid is noise and not the sampling of a thin part: a
# Gaussian erodes a vessel three pixels in radius sampled in slices twice as thick, and the share it
# disagrees on reads 0.05-0.09 where the surface is clean; without the erosion clean label maps of
# analytic solids at such spacings measure at most 0.021 (0.030 for a small box whose edges are a large
# part of its surface), noise of a quarter of the boundary voxels flipped 0.15-0.19
# (benchmarks/surfaces.py). Not asked of cubic voxels: there a smoother noise (segmentation noise
# smoothed over 1.75 voxels, benchmarks/volumes.py) reads 0.015-0.02 and needs the fine pass.
LEAST_SHRINK_FREE_ROUGHNESS = 0.025
# The noise height (voxels) as a line in the roughness: parts of the input standing higher above
# a smoothing are features (about 2 voxels for noise of 0.6, 3 for noise of 1).
HEIGHT_AT_ZERO = 1.0
HEIGHT_PER_ROUGHNESS = 20.0
SIGMA_PER_ROUGHNESS = 25.0  # the widest sigma (voxels) as a line in the roughness, at most LEVELS[0]
# From this roughness the noise is voxels flipped one by one along the surface (a quarter of the
# boundary voxels flipped measures 0.19-0.24; segmentation noise of standard deviation 1 voxel at most
# 0.11), and the levels are twiced Gaussians: a Gaussian's threshold moves a curved surface in by its
# curvature times sigma squared, and with flipped voxels the widest sigma is 2: a ball of radius 11
# voxels lost 10 % of its volume and a rod three voxels in radius 59 %; twiced, 4 % and 23 %
# (benchmarks/surfaces.py's label maps). Below it the Gaussian: on segmentation noise twicing smooths
# weak noise on flat parts less (a block 0.80 of the input's error against 0.67) and leaves a chair's
# high bumps on its legs, which the Gaussian's erosion lets the stages find (0.97 against 0.33).
FLIPPED_ROUGHNESS = 0.15
# Sigmas: the reach over which `smoothed_volume_kept` gives the smoothing back the mask's volume. Twiced
# Gaussians still take a thin or curved part in where its flips are as deep as it is thick (the rod
# three voxels in radius: 23 % of its volume; a ball of radius 11 voxels 4 %); flips take as many
# voxels out as they put in, so the voxels' own volume is where the surface is (rod 0.37 -> 0.14 mm
# from its true surface, ball 0.17 -> 0.11; benchmarks/surfaces.py's boundary noise).
VOLUME_REACH = 2.0
GROW = 2  # voxels around a feature left to the next level
SPECK_RADIUS = 2.0  # voxels: pieces and pockets smaller than this ball are noise (islands, pits)


@dataclass(frozen=True)
class VoxelRoughness:
    """What `voxel_roughness` found.

    Attributes
    ----------
    found : bool
        The roughness reaches `LEAST_ROUGHNESS`.
    roughness : float
        Share of the light smoothing's surface voxels where the mask disagrees with it.
    height : float
        Voxels: the height above a smoothing from which a part is a feature (0 when not found).
    widest : float
        Voxels: the widest sigma the roughness allows (`SIGMA_PER_ROUGHNESS`, at most ``LEVELS[0]``).
    shrink_free : float or None
        The share against the shrink-free light smoothing, where the roughness reached
        `LEAST_ROUGHNESS`.
    """

    found: bool
    roughness: float
    height: float
    widest: float
    shrink_free: float | None = None

    @property
    def levels(self):
        """The sigmas of `LEVELS` that smooth, widest first (at least the narrowest)."""
        return tuple(s for s in LEVELS if s <= self.widest) or LEVELS[-1:]

    def describe(self):
        """One line a user can read."""
        if not self.found and self.shrink_free is not None:
            return (f"fine noise: none found (the surface disagrees with its light smoothing on "
                    f"{100 * self.roughness:.1f} %, but on {100 * self.shrink_free:.1f} % with thin parts "
                    f"not eroded, from {100 * LEAST_SHRINK_FREE_ROUGHNESS:.1f} % it is noise: the sampling of "
                    "thin parts or thick slices)")
        if not self.found:
            return (f"fine noise: none found (the surface disagrees with its light smoothing on "
                    f"{100 * self.roughness:.1f} %, from {100 * LEAST_ROUGHNESS:.1f} % it is noise)")
        return (f"fine noise on {100 * self.roughness:.1f} % of the surface: smoothed up to sigma "
                f"{self.levels[0]:g} voxels, parts standing {self.height:.1f} voxels or more kept")


def smoothed(mask, sigma):
    """The mask's Gaussian of ``sigma`` voxels, thresholded at one half."""
    return gaussian_filter(mask.astype(np.float32), sigma) > 0.5


def smoothed_shrink_free(mask, sigma):
    """The mask's twiced Gaussian (``2 G m - G G m``) of ``sigma`` voxels, thresholded at one half: a
    light smoothing that does not erode thin parts."""
    once = gaussian_filter(mask.astype(np.float32), sigma)
    return 2 * once - gaussian_filter(once, sigma) > 0.5


def smoothed_volume_kept(mask, sigma):
    """`smoothed_shrink_free`, its surface then moved out or in where it encloses fewer or more voxels
    than ``mask`` within `VOLUME_REACH` sigmas: the smoothing of voxels flipped at random, which take
    as many voxels out of the surface as they put in, and whose surface is where the mask's volume is.

    With ``s`` the twiced Gaussian, ``m`` the mask, ``o = s > 1/2`` and ``b`` the voxels on either side
    of ``o``'s surface, the move (voxels, > 0 out) near each voxel is the volume missing there over the
    surface there, ``d = G (m - o) / (G b / 2)`` with ``G`` the Gaussian of `VOLUME_REACH` sigmas, at
    most a voxel; the result is ``s > 1/2 - d |grad s|`` (the threshold moved by the surface's move
    times the field's slope there)."""
    values = mask.astype(np.float32)
    once = gaussian_filter(values, sigma)
    smooth = 2 * once - gaussian_filter(once, sigma)
    out = smooth > 0.5
    reach = VOLUME_REACH * sigma
    missing = gaussian_filter(values - out, reach)
    surface = gaussian_filter(_boundary(out).astype(np.float32), reach) / 2
    move = np.divide(missing, surface, out=np.zeros_like(missing), where=surface > 1e-3)
    slope = np.sqrt(sum(g * g for g in np.gradient(smooth)))
    return smooth > 0.5 - np.clip(move, -1.0, 1.0) * slope


def _disagreement(mask, light):
    """Share of ``light``'s surface voxels (both sides) where ``mask`` disagrees with it."""
    boundary = _boundary(light)
    return float(np.count_nonzero(mask[boundary] != light[boundary]) / max(np.count_nonzero(boundary), 1))


def _boundary(mask):
    """The voxels on either side of the mask's surface (6-neighbours across it)."""
    return surface_voxels(mask) | (dilated_by_cross(mask) & ~mask)


def voxel_roughness(mask, sampled=False):
    """How rough the surface of ``mask`` is, and whether that is noise.

    The roughness is the share of the surface voxels of the light smoothing
    (`smoothed` at `MEASURE_SIGMA`, both sides of its surface) where ``mask`` disagrees with it. It
    is noise from `LEAST_ROUGHNESS`; for a ``sampled`` mask (thick slices on their own grid), where
    the shrink-free light smoothing (`smoothed_shrink_free`) disagrees from
    `LEAST_SHRINK_FREE_ROUGHNESS` too: a clean thin part that the Gaussian erodes is the sampling of
    a smooth surface, not noise.

    Returns
    -------
    VoxelRoughness

    Examples
    --------
    >>> import numpy as np
    >>> cube = np.zeros((30, 30, 30), bool); cube[5:25, 5:25, 5:25] = True
    >>> voxel_roughness(cube).found
    False
    """
    box = bounding_box(mask, margin=4)
    if box is None:
        return VoxelRoughness(False, 0.0, 0.0, 0.0)
    mask = mask[box]
    roughness = _disagreement(mask, smoothed(mask, MEASURE_SIGMA))
    if roughness < LEAST_ROUGHNESS:
        return VoxelRoughness(False, roughness, 0.0, 0.0)
    shrink_free = _disagreement(mask, smoothed_shrink_free(mask, MEASURE_SIGMA)) if sampled else None
    if sampled and shrink_free < LEAST_SHRINK_FREE_ROUGHNESS:
        return VoxelRoughness(False, roughness, 0.0, 0.0, shrink_free)
    return VoxelRoughness(True, roughness, HEIGHT_AT_ZERO + HEIGHT_PER_ROUGHNESS * roughness,
                          min(SIGMA_PER_ROUGHNESS * roughness, LEVELS[0]), shrink_free)


def _features(mask, smooth, height):
    """Voxels where ``smooth`` removed or added a part standing higher than ``height``, or cut ``mask`` apart."""
    kept = feature_restore.features_by_extent(mask, smooth, height)
    kept |= feature_restore.connections(mask, smooth | kept, height)
    kept |= feature_restore.features_by_extent(~mask, ~smooth, height)
    return kept


def fine_pass(mask, sampled=None):
    """Smooth the fine noise of a binary volume, keeping whatever stands out of it.

    Parameters
    ----------
    mask : bool ndarray
        The shape (where it touches the array's faces, smoothed as if mirrored there).
    sampled : bool ndarray, optional
        The same shape on the grid it was sampled on, where ``mask`` is its resampling to cubic
        voxels (`skelfilter.core.spacing.to_isotropic`): its noise is measured there first
        (`voxel_roughness` of a sampled mask), then on ``mask`` with the same shrink-free check. Thick
        slices resampled to cubic voxels disagree with their light smoothing where the slices end (a
        clean torus at slices twice as thick as its pixels: 4.5 %, where 3.5 % is noise), which is
        sampling, not noise.

    Returns
    -------
    mask : bool ndarray
        The smoothed shape (``mask`` itself, unchanged, when no noise is found).
    noise : VoxelRoughness
    """
    if sampled is not None:
        noise = voxel_roughness(sampled, sampled=True)
        if not noise.found:
            return mask, noise
    noise = voxel_roughness(mask, sampled=sampled is not None)
    if not noise.found:
        return mask, noise
    margin = int(np.ceil(3 * LEVELS[0] + noise.height)) + GROW + 2
    box = bounding_box(mask, margin=margin)
    inner = mask[box] ^ edt_filters.specks(mask[box], SPECK_RADIUS)
    result = inner.copy()
    undecided = np.ones_like(inner)
    smoothing = smoothed_volume_kept if noise.roughness >= FLIPPED_ROUGHNESS else smoothed
    for sigma in noise.levels:
        smooth = smoothing(inner, sigma)
        features = _features(inner, smooth, noise.height)
        if features.any():
            features = dilated_by_cross(features, GROW)
        decide = undecided & ~features
        result[decide] = smooth[decide]
        undecided &= features
        if not undecided.any():
            break
    out = mask.copy()
    out[box] = result
    return out, noise
