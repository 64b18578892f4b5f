"""The continuous field whose 0-level is the output surface: balls' union of a binary volume, and
the input's own distances kept where the denoising changed nothing."""

import numpy as np
from scipy import ndimage

from skelfilter.core import reconstruct

# Balls of radius D touch the centres of the nearest outside voxels; the
# boundary between inside and outside voxel centres is half a voxel further in.
SURFACE_OFFSET = 0.5



def unchanged_band(field, mask, occupancy, reach):
    """Flat indices of the voxels whose field values shape the 0-level (``|field| < 1.5``) and lie
    more than ``reach`` voxels (6-connected steps) from any voxel the denoising changed."""
    near_change = ndimage.binary_dilation(mask != occupancy, iterations=reach)
    return np.flatnonzero((np.abs(field) < 1.5).reshape(-1) & ~near_change.reshape(-1))


def put_distances(field, mask, band, distance):
    """``field[band]`` = ``distance`` with the mask's sign, so the mesh and the voxels still agree."""
    flat = field.reshape(-1)
    flat[band] = np.where(mask.reshape(-1)[band], 1.0, -1.0) * np.maximum(np.abs(distance), 1e-3)


def keep_input_field(field, mask, occupancy, input_field, reach=2):
    """`skelfilter.mesh.marching_cubes.keep_input_surface` for a volume: where the denoising changed
    nothing, ``field`` takes the input's own ``input_field`` (in voxels, > 0 inside, e.g.
    `skelfilter.core.spacing.signed_distance`). In place."""
    band = unchanged_band(field, mask, occupancy, reach)
    put_distances(field, mask, band, input_field.reshape(-1)[band])


def mask_field(mask):
    """Continuous field of a binary volume: the union of the balls of all its voxels.

    Same construction as the pipeline's reconstruction without pruning, so
    meshes of noisy and of denoised volumes are extracted alike.
    """
    distance = ndimage.distance_transform_edt(mask)
    centres = np.flatnonzero(mask.reshape(-1))
    radii = distance.reshape(-1)[centres] - SURFACE_OFFSET
    return reconstruct.union_of_balls(mask.shape, centres, radii)[1]
