"""Measures on the voxelized result: IoU, the noise removed, shrinkage, thin parts kept.
"""

import numpy as np
from scipy import ndimage

from skelfilter.errors import ParameterError
from skelfilter.mesh.voxelize import voxelize_on_grid


def volumetric_iou(result, clean, grid):
    """Intersection over union of the two meshes' voxelizations on ``grid``.

    Both are voxelized with `skelfilter.mesh.voxelize.voxelize_on_grid`.

    Returns
    -------
    float
        ``|V(result) ∩ V(clean)| / |V(result) ∪ V(clean)|``; NaN when both are empty.
    """
    return mask_iou(voxelize_on_grid(result, grid), voxelize_on_grid(clean, grid))


def mask_iou(a, b):
    """Intersection over union of two boolean volumes; NaN when both are empty."""
    union = np.count_nonzero(a | b)
    return float("nan") if union == 0 else float(np.count_nonzero(a & b) / union)


def noise_removed(result, noise, grid, result_volume=None):
    """Share of the synthetic noise that the result removed.

    A bump voxel is removed when the result's voxelization lacks it, a dent
    voxel when the voxelization has it.

    Parameters
    ----------
    result : trimesh.Trimesh
    noise : NoiseResult-like
        Any object with boolean volumes ``bumps`` and ``dents`` of ``grid.shape``
        (e.g. `skelfilter.core.synthetic_noise.NoiseResult`).
    grid : voxelize.Grid

    Returns
    -------
    dict
        ``noise_removed`` (bumps and dents removed over all noise voxels),
        ``bumps_removed``, ``dents_removed`` (each NaN when there is no such voxel).
    """
    v = result_volume if result_volume is not None else voxelize_on_grid(result, grid)
    bumps, dents = _noise_masks(noise, grid)
    nb, nd = np.count_nonzero(bumps), np.count_nonzero(dents)
    rb, rd = np.count_nonzero(bumps & ~v), np.count_nonzero(dents & v)
    nan = float("nan")
    return {
        "noise_removed": float((rb + rd) / (nb + nd)) if nb + nd else nan,
        "bumps_removed": float(rb / nb) if nb else nan,
        "dents_removed": float(rd / nd) if nd else nan,
    }


def _noise_masks(noise, grid):
    bumps = np.asarray(noise.bumps, dtype=bool)
    dents = np.asarray(noise.dents, dtype=bool)
    if bumps.shape != tuple(grid.shape) or dents.shape != tuple(grid.shape):
        raise ParameterError(f"noise masks have shape {bumps.shape}/{dents.shape}, the grid {grid.shape}")
    return bumps, dents


def shrinkage(result, clean, grid, noise=None, reach=6.1, result_volume=None, clean_volume=None):
    """Share of the clean volume lost away from the noise.

    Counts the clean voxels (of ``clean``'s voxelization) farther than
    ``reach`` voxels (Euclidean, centre to centre) from every bump or dent
    voxel, and returns the share of them missing from the result's
    voxelization. Without ``noise`` every clean voxel counts.

    Parameters
    ----------
    result, clean : trimesh.Trimesh
    grid : voxelize.Grid
    noise : NoiseResult-like, optional
        Boolean ``bumps`` and ``dents`` volumes of ``grid.shape``.
    reach : float, optional
        In voxels; the default suits the thesis' noise (h = 3, r = 2.1) plus a voxel.

    Returns
    -------
    float
        In [0, 1]; NaN when no clean voxel is that far from the noise.
    """
    v = result_volume if result_volume is not None else voxelize_on_grid(result, grid)
    c = clean_volume if clean_volume is not None else voxelize_on_grid(clean, grid)
    far = c
    if noise is not None:
        bumps, dents = _noise_masks(noise, grid)
        near = bumps | dents
        if near.any():
            far = c & (ndimage.distance_transform_edt(~near) > reach)
    n = np.count_nonzero(far)
    return float("nan") if n == 0 else float(np.count_nonzero(far & ~v) / n)


def thin_parts(clean, radius=4.0):
    """The voxels of ``clean`` that an opening by a ball of ``radius`` voxels removes: its thin parts
    (plates, rods, rims thinner than ``2 radius``) and the voxels of its convex edges and corners.

    The opening is computed with distance transforms (the erosion is the voxels deeper than
    ``radius``, the dilation the voxels within ``radius`` of those), so it is the opening by the
    Euclidean ball of that radius (centres within it).
    """
    clean = np.asarray(clean, dtype=bool)
    core = ndimage.distance_transform_edt(clean) > radius
    if not core.any():
        return clean.copy()
    opened = ndimage.distance_transform_edt(~core) <= radius
    return clean & ~opened


def thin_parts_kept(result_volume, thin):
    """Share of the ``thin`` voxels (`thin_parts` of the clean shape) that ``result_volume`` holds; NaN
    when there are none."""
    n = np.count_nonzero(thin)
    return float(np.count_nonzero(thin & result_volume) / n) if n else float("nan")
