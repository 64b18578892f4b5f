"""Measures on the voxelized result: IoU, the noise removed, shrinkage, thin parts kept, the noise left by
the thickness of the part under it, the clean shape's concavities filled.
"""

import numpy as np
from scipy import ndimage, spatial

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


def thickness_under(outside, clean, thickness):
    """Which voxels of ``outside`` (those not in ``clean``) stand on a part of ``clean`` thicker than
    ``thickness`` voxels: their nearest clean voxel lies in the opening of ``clean`` by a ball of
    diameter ``thickness`` (`thin_parts` is the rest of ``clean``); measured centre to centre as
    `thin_parts` measures, a slab of n voxels is thicker than n - 1 and not than n + 1.

    A bump on a body or a head reads as thick, one on a leg, a fin or a rim, or at a convex edge, as
    thin.

    Returns
    -------
    ndarray of bool, the shape of ``clean``
        True at the voxels of ``outside`` standing on a part that thick.
    """
    clean = np.asarray(clean, dtype=bool)
    outside = np.asarray(outside, dtype=bool) & ~clean
    thick = clean & ~thin_parts(clean, thickness / 2.0)
    if not outside.any() or not thick.any():
        return np.zeros(clean.shape, dtype=bool)
    nearest = ndimage.distance_transform_edt(~clean, return_distances=False, return_indices=True)
    under = tuple(axis[outside] for axis in nearest)
    result = np.zeros(clean.shape, dtype=bool)
    result[outside] = thick[under]
    return result


def concavities(clean, depth):
    """The clean shape's concavities deeper than ``depth`` voxels: the voxels inside the convex hull
    of its voxels' centres, outside it, farther than ``depth`` from it (a mug's inside, a channel, the
    space between legs, less the layer in which surface noise lies).

    Returns
    -------
    ndarray of bool, the shape of ``clean``
    """
    clean = np.asarray(clean, dtype=bool)
    deep = ndimage.distance_transform_edt(~clean) > depth
    result = np.zeros(clean.shape, dtype=bool)
    points = np.argwhere(clean)
    if len(points) < 4 or np.linalg.matrix_rank(points[1:] - points[0]) < 3:
        return result  # flat: no hull with a volume
    hull = spatial.ConvexHull(points)
    low, high = points.min(axis=0), points.max(axis=0) + 1
    box = tuple(slice(lo, hi) for lo, hi in zip(low, high))
    candidates = np.argwhere(deep[box]) + low
    if len(candidates):
        inside = spatial.Delaunay(points[hull.vertices]).find_simplex(candidates) >= 0
        result[tuple(candidates[inside].T)] = True
    return result


def concavity_filled(result_volume, concave):
    """Share of the ``concave`` voxels (`concavities` of the clean shape) that ``result_volume`` fills;
    NaN when there are none."""
    n = np.count_nonzero(concave)
    return float(np.count_nonzero(concave & result_volume) / n) if n else float("nan")
