"""From volumes back to meshes: marching cubes at sub-voxel precision."""

import numpy as np
import trimesh
from scipy import ndimage
from skimage import measure

from . import reconstruct
from .neighbourhood import bounding_box

# Balls of radius D touch the centres of the nearest outside voxels; the
# boundary between inside and outside voxel centres is half a voxel further in.
SURFACE_OFFSET = 0.5


def field_to_mesh(field, grid):
    """Marching cubes of the 0-level of ``field`` (> 0 inside) in world coordinates.

    Parameters
    ----------
    field : float ndarray
        Continuous field over ``grid``; must be negative on the volume's faces
        so the surface is closed.
    grid : voxelize.Grid

    Returns
    -------
    trimesh.Trimesh
        Watertight, outward-oriented mesh.
    """
    crop = bounding_box(field > 0, margin=2)
    if crop is None:
        raise ValueError("the field has no inside: nothing to mesh")
    lo = np.array([s.start for s in crop])
    verts, faces, _, _ = measure.marching_cubes(np.ascontiguousarray(field[crop], dtype=np.float32), level=0.0)
    mesh = trimesh.Trimesh(grid.to_world(verts + lo), faces, process=True)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def mask_field(mask):
    """Continuous field of a binary volume: the union of the balls of all its voxels.

    Same construction as the pipeline's reconstruction without pruning, so
    meshes of noisy and of denoised volumes are extracted alike.
    """
    distance = ndimage.distance_transform_edt(mask)
    centres = np.flatnonzero(mask.reshape(-1))
    radii = distance.reshape(-1)[centres] - SURFACE_OFFSET
    return reconstruct.union_of_balls(mask.shape, centres, radii)[1]


def mask_to_mesh(mask, grid):
    """Mesh of a binary volume (e.g. a noisy voxel model) in world coordinates."""
    return field_to_mesh(mask_field(mask), grid)
