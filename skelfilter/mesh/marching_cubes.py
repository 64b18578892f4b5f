"""From volumes back to meshes: marching cubes at sub-voxel precision."""

import numpy as np
import trimesh
from skimage import measure

from skelfilter.core.neighbourhood import bounding_box, unravel
from skelfilter.core.surface_field import mask_field, put_distances, unchanged_band
from skelfilter.mesh.closest_points import MeshSurface
from skelfilter.mesh.voxelize import Grid


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

    References
    ----------
    .. [1] W. E. Lorensen, H. E. Cline, "Marching cubes: a high resolution 3D surface construction
           algorithm", SIGGRAPH 1987; T. Lewiner, H. Lopes, A. W. Vieira, G. Tavares, "Efficient
           implementation of marching cubes' cases with topological guarantees", Journal of Graphics
           Tools 8(2), 2003 (scikit-image's).
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


def field_to_world_mesh(field, affine):
    """Marching cubes of the 0-level of ``field`` (> 0 inside) on a grid whose voxel indices go to
    the world through the 4x4 ``affine`` (a scanner's volume); closed even where the inside
    touches the grid's border.

    Returns
    -------
    trimesh.Trimesh
        Watertight, outward-oriented mesh in world coordinates.
    """
    padded = np.pad(np.asarray(field, dtype=np.float32), 1, constant_values=-1.0)
    mesh = field_to_mesh(padded, Grid(origin=(-1.0, -1.0, -1.0), pitch=1.0, shape=padded.shape))
    affine = np.asarray(affine, dtype=float)
    mesh.vertices = mesh.vertices @ affine[:3, :3].T + affine[:3, 3]
    if np.linalg.det(affine[:3, :3]) < 0:
        mesh.invert()
    return mesh


def keep_input_surface(field, mask, occupancy, mesh, grid, reach=2):
    """Put the input mesh's own surface into ``field`` wherever the denoising changed nothing, in place.

    Voxels whose occupancy is the input's and lies more than ``reach`` voxels
    (6-connected steps) from any changed voxel take the input mesh's distance
    (in voxels, > 0 inside) instead of the reconstruction's, so that there the
    output surface is the input's to sub-voxel precision, edges and corners
    included, rather than the half-voxel-accurate union of balls. Only the band
    of voxels whose values shape the 0-level (``|field| < 1.5``) is touched;
    the sign stays the mask's, so the mesh and the voxels still agree.

    Parameters
    ----------
    field : float ndarray
        The reconstruction's field over ``grid`` (> 0 inside), modified in place.
    mask, occupancy : bool ndarray
        The denoised and the input voxels on ``grid``.
    mesh : trimesh.Trimesh
        The input mesh.
    grid : voxelize.Grid
    reach : int, optional
        Voxels kept clear of every change.
    """
    band = unchanged_band(field, mask, occupancy, reach)
    if band.size == 0:
        return
    points = grid.to_world(unravel(band, field.shape)).astype(np.float32)
    put_distances(field, mask, band, MeshSurface(mesh).distance(points) / grid.pitch)


def mask_to_mesh(mask, grid):
    """Mesh of a binary volume (e.g. a noisy voxel model) in world coordinates."""
    return field_to_mesh(mask_field(mask), grid)
