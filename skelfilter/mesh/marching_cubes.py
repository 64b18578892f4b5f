"""From volumes back to meshes: marching cubes at sub-voxel precision, of the field smoothed under
the voxels' constraint (`skelfilter.core.surface_field.smooth_constrained`) where the surface is made
from voxels: smooth, and enclosing exactly the voxels it is of."""

import numpy as np
import trimesh
from scipy import ndimage
from skimage import measure

from skelfilter.core import spacing as voxel_spacing
from skelfilter.core.neighbourhood import bounding_box, unravel
from skelfilter.core.surface_field import (
    SMOOTHING_ROUNDS,
    SMOOTHING_SIGMA,
    mask_field,
    put_distances,
    smooth_constrained,
    unchanged_band,
)
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
    if _signed_volume(mesh.vertices, mesh.faces) < 0:
        mesh.invert()
    return mesh


def _signed_volume(vertices, faces):
    """The volume a closed triangle mesh encloses, negative where its faces wind inwards: the sum of
    the tetrahedra from the origin to each face, ``v0 . (v1 x v2) / 6`` (trimesh's ``volume`` finds
    it among all the mass properties, twelve times slower on a surface of a million faces)."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->", a, np.cross(b, c))) / 6.0


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


# Voxels around a mask's bounding box that the smoothing reads: past them a value moves its surface
# by less than a thousandth of a voxel.
SMOOTHING_REACH = int(np.ceil(4 * SMOOTHING_SIGMA * np.sqrt(2 * SMOOTHING_ROUNDS))) + 2


def smooth_field_to_mesh(field, mask, grid, fixed=None):
    """`field_to_mesh` of ``field`` smoothed under ``mask``'s constraint (`smooth_constrained`), the
    values of the ``fixed`` voxels (flat indices) held: the closed mesh of the voxel stage, whose
    surface is the input's own where nothing changed and smooth elsewhere, and encloses exactly
    ``mask``'s voxels. Not moved to the voxels' volume: where the pruning removed bumps their stubs
    are voxels too, and the smoothing's rounding takes them down (moved out, the normal error rose on
    63 of the 64 changed cases of benchmarks/quality.py, and the noise left on all 64)."""
    held = np.zeros(field.shape, dtype=bool)
    if fixed is not None:
        held.reshape(-1)[fixed] = True
    # Only the surface the fixed values do not give needs smoothing: its box, widened by the smoothing's reach.
    box = bounding_box((field < 1.5) & (field > -1.5) & ~held, margin=SMOOTHING_REACH)
    if box is not None:
        part = smooth_constrained(np.ascontiguousarray(field[box]), mask[box], held[box], match_volume=False,
                                  overwrite=True)
        field = field.copy()
        field[box] = part
        del part
    return field_to_mesh(field, grid)


def mask_to_world_mesh(mask, affine, smooth=True):
    """The surface of a voxel mask in the world coordinates of the 4x4 ``affine`` (voxel index to
    world): closed, outward, enclosing exactly the mask's voxel centres.

    ``smooth``: the mask's signed distance (world units, the affine's spacing: thick slices are
    ramps, not steps) smoothed under the voxels' constraint (`smooth_constrained`): the smooth surface
    that a clean mask samples, staircase and all; else its plain marching cubes (half-way between
    centres).
    """
    mask = np.asarray(mask, dtype=bool)
    box = bounding_box(mask, margin=SMOOTHING_REACH)
    if box is None:
        raise ValueError("the mask is empty: nothing to mesh")
    affine = np.asarray(affine, dtype=float)
    spacing = np.linalg.norm(affine[:3, :3], axis=0)
    # outside beyond the array's faces too, so the surface closes there
    part = np.pad(mask[box], SMOOTHING_REACH)
    shift = np.eye(4)
    shift[:3, 3] = [b.start - SMOOTHING_REACH for b in box]
    field = voxel_spacing.signed_distance(part, spacing)
    if smooth:
        field = smooth_constrained(field, part, spacing=spacing)
    return field_to_world_mesh(field, affine @ shift)


def labels_to_world_meshes(labels, affine, which=None):
    """The surfaces of a label map's labels, each as `mask_to_world_mesh`'s, sharing their boundaries.

    Each label ``L``'s field is its smoothed signed distance ``s_L`` (`smooth_constrained`, the
    background's too) less the largest of the other labels' there, ``s_L - max_{M != L} s_M``: where
    two labels touch, their fields are each other's negative, so their surfaces are one (no gap, no
    overlap), and each still encloses exactly its own voxels' centres (``s_L > 0 > s_M`` there).

    Parameters
    ----------
    labels : int ndarray
        The label map; 0 is the background.
    affine : (4, 4) array_like
        Voxel index to world.
    which : sequence of int, optional
        The labels to mesh (default: every nonzero label present).

    Returns
    -------
    dict
        Label -> closed, outward `trimesh.Trimesh` in world coordinates.
    """
    labels = np.asarray(labels)
    present = [int(v) for v in np.unique(labels) if v != 0]
    which = present if which is None else [int(v) for v in which]
    missing = sorted(set(which) - set(present))
    if missing:
        raise ValueError(f"labels {missing} select no voxel")
    affine = np.asarray(affine, dtype=float)
    spacing = np.linalg.norm(affine[:3, :3], axis=0)
    reach = SMOOTHING_REACH
    padded = np.pad(labels, reach)  # background beyond the array's faces
    shift = np.eye(4)
    shift[:3, 3] = -reach
    fields = {}  # label -> (box, smoothed signed distance over it); the background's box is the whole map
    for value in [0, *present]:
        mask = padded == value
        box = bounding_box(mask, margin=reach)
        part = mask[box]
        fields[value] = (box, smooth_constrained(voxel_spacing.signed_distance(part, spacing), part,
                                                 spacing=spacing))
    meshes = {}
    for value in which:
        box, own = fields[value]
        others = np.full(own.shape, -np.inf, dtype=np.float32)  # the largest of the other labels' fields
        first = own.copy()  # the largest and second largest of every label's field
        second = np.full(own.shape, -np.inf, dtype=np.float32)
        for other, (other_box, field) in fields.items():
            if other == value:
                continue
            overlap = tuple(slice(max(a.start, b.start), min(a.stop, b.stop)) for a, b in zip(box, other_box))
            if any(o.start >= o.stop for o in overlap):
                continue
            mine = tuple(slice(o.start - a.start, o.stop - a.start) for o, a in zip(overlap, box))
            theirs = tuple(slice(o.start - b.start, o.stop - b.start) for o, b in zip(overlap, other_box))
            np.maximum(others[mine], field[theirs], out=others[mine])
            np.maximum(second[mine], np.minimum(first[mine], field[theirs]), out=second[mine])
            np.maximum(first[mine], field[theirs], out=first[mine])
        field = own - others
        # On the grid edges from this label's voxels to another's, the two surfaces cross at one point
        # when each field at the other's voxel is the negative of that voxel's own margin (its label's
        # field less the runner-up's): where a third label is the runner-up there, it would part them.
        label = padded[box]
        across = ndimage.binary_dilation(label == value) & (label != value)
        field[across] = second[across] - first[across]
        local = np.eye(4)
        local[:3, 3] = [b.start for b in box]
        meshes[value] = field_to_world_mesh(field, affine @ shift @ local)
    return meshes


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

    Returns
    -------
    int ndarray
        The flat indices of the voxels given the input's distance.
    """
    band = unchanged_band(field, mask, occupancy, reach)
    if band.size == 0:
        return band
    points = grid.to_world(unravel(band, field.shape)).astype(np.float32)
    put_distances(field, mask, band, MeshSurface(mesh).distance(points) / grid.pitch)
    return band


def mask_to_mesh(mask, grid):
    """Mesh of a binary volume (e.g. a noisy voxel model) in world coordinates."""
    return field_to_mesh(mask_field(mask), grid)
