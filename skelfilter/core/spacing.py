"""Anisotropic voxels: to an isotropic grid for the pipeline, and back.

Scanners often give thick slices (0.5 x 0.5 x 1.5 mm). The skeleton, the distances and the
thresholds of the pipeline assume cubic voxels, so a mask with another spacing is resampled to
cubic voxels of the finest spacing first: its signed distance (computed with the true spacing)
is interpolated linearly and cut at zero, which turns the stair-steps of thick slices into the
ramps they sample. The denoised field goes back the same way. Voxel centres are aligned: the
centre of voxel ``n`` along an axis lies at ``(n + 1/2) * spacing`` on both grids.
"""

import numpy as np
from scipy import ndimage


def is_isotropic(spacing, tolerance=1e-4):
    """Equal sides to ``tolerance`` (relative): headers store spacings in float32 and rounded."""
    spacing = np.asarray(spacing, dtype=float)
    return bool(np.ptp(spacing) <= tolerance * spacing.max())


def isotropic_shape(shape, spacing):
    """The cubic-voxel grid (voxels of the finest spacing) covering a grid of ``shape``."""
    spacing = np.asarray(spacing, dtype=float)
    return tuple(int(n) for n in np.ceil(np.asarray(shape) * spacing / spacing.min() - 1e-9))


def signed_distance(mask, spacing):
    """Half the difference of the distances to the nearest outside and inside voxel centres, in
    world units: > 0 inside, 0 half-way between an inside and an outside centre."""
    inside = ndimage.distance_transform_edt(mask, sampling=spacing)
    outside = ndimage.distance_transform_edt(~mask, sampling=spacing)
    return ((inside - outside) / 2).astype(np.float32)


def _resample(values, scale, shape):
    """Linear interpolation of ``values`` at the centres of a grid whose voxels are ``scale`` times
    as large (per axis), ``shape`` voxels."""
    scale = np.asarray(scale, dtype=float)
    return ndimage.affine_transform(values, scale, offset=(scale - 1) / 2, output_shape=shape, order=1,
                                    mode="nearest")


def to_isotropic(mask, spacing):
    """``mask``'s signed distance on cubic voxels of the finest spacing, in those voxels; its
    positive voxels are the resampled mask.

    Returns
    -------
    field : float32 ndarray, shape `isotropic_shape`
    pitch : float
        The cubic voxels' size in world units.
    """
    spacing = np.asarray(spacing, dtype=float)
    pitch = float(spacing.min())
    field = _resample(signed_distance(np.asarray(mask, dtype=bool), spacing), pitch / spacing,
                      isotropic_shape(mask.shape, spacing))
    return field / np.float32(pitch), pitch


def from_isotropic(field, spacing, shape):
    """A field on the cubic grid of `to_isotropic`, back on the grid of ``shape`` and ``spacing``."""
    spacing = np.asarray(spacing, dtype=float)
    return _resample(np.asarray(field, dtype=np.float32), spacing / spacing.min(), shape)
