"""Euclidean distance transform and feature transform (thesis §2.2, eq. 2.4–2.5)."""

import numpy as np
from scipy import ndimage


def distance_and_features(volume):
    """EDT ``D`` of a set and, per voxel, one nearest background voxel.

    Parameters
    ----------
    volume : (nx, ny, nz) bool ndarray
        The set X. It must leave at least one background voxel.

    Returns
    -------
    distance : float32 ndarray
        ``D(x) = min {|x - y| : y not in X}`` (eq. 2.4); 0 on the background,
        so foreground voxels touching the background have ``D = 1``.
    features : (3, nx, ny, nz) int32 ndarray
        Coordinates of one element ``f(x)`` of the feature transform
        ``F(x)`` (eq. 2.5). For ``x`` in X it lies in the boundary layer
        ``M = (X ⊕ b) \\ X`` (eq. 7.12).
    """
    volume = np.asarray(volume, dtype=bool)
    if volume.all():
        raise ValueError("the set fills the whole volume: no background to measure distances to")
    distance, features = ndimage.distance_transform_edt(volume, return_indices=True)
    return distance.astype(np.float32), features


def feature_points(features, voxels):
    """Flat indices of the feature points ``f(x)`` of the given flat voxel indices."""
    shape = features.shape[1:]
    coords = np.unravel_index(voxels, shape)
    f = features[(slice(None),) + coords].astype(np.int64)
    return (f[0] * shape[1] + f[1]) * shape[2] + f[2]


def gradient_at(distance, voxels):
    """Central-difference gradient of ``distance`` at flat voxel indices, shape ``(n, 3)``.

    The voxels must not lie on the volume's faces (the pipeline pads).
    """
    flat = distance.reshape(-1)
    shape = distance.shape
    strides = (shape[1] * shape[2], shape[2], 1)
    g = np.empty((len(voxels), 3), dtype=np.float32)
    for axis, s in enumerate(strides):
        g[:, axis] = 0.5 * (flat[voxels + s] - flat[voxels - s])
    return g
