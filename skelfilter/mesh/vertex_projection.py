"""The user's own mesh as output: its vertices moved onto the denoised surface.

Instead of a new marching-cubes mesh, the input mesh comes back with the same faces in the same
order (so per-vertex and per-face colours, UVs and an open boundary survive). Vertices where the
voxel stage changed the shape (a removed bump, a filled dent) are pulled along the gradient of the
denoised field onto its 0-level (`project_onto_field`). A bump's side walls then collapse onto its
footprint; `relax_on_field` spreads those vertices over the surface again (tangential Laplacian
steps, each followed by a projection), which with the ring of unmoved vertices held fixed is
Tutte's convex-combination map on a nearly flat patch and so unfolds it. `folded_faces` says which
faces still point against the surface or have lost their area.
"""

import numpy as np
from scipy import ndimage

from skelfilter.core.neighbourhood import bounding_box, dilated_by_cross, surface_voxels
from skelfilter.mesh.normal_filtering import face_edges, vertex_adjacency
from skelfilter.runtime.signals import checkpoint

# A face is degenerate when its area falls under this share of the mesh's mean face area.
DEGENERATE_AREA = 1e-4


def sample_field(field, points):
    """Trilinear values and central-difference gradients of ``field`` at voxel coordinates.

    Parameters
    ----------
    field : (nx, ny, nz) float array
    points : (n, 3) float array of fractional voxel coordinates

    Returns
    -------
    values : (n,) float array
    gradients : (n, 3) float array (per voxel)
    """
    coords = np.asarray(points, dtype=np.float64).T
    values = ndimage.map_coordinates(field, coords, order=1, mode="nearest")
    gradients = np.empty((len(points), 3))
    for axis in range(3):
        step = np.zeros((3, 1))
        step[axis] = 0.5
        gradients[:, axis] = (ndimage.map_coordinates(field, coords + step, order=1, mode="nearest")
                              - ndimage.map_coordinates(field, coords - step, order=1, mode="nearest"))
    return values, gradients


def project_onto_field(points, field, iterations=6, max_step=2.0, level=0.0):
    """Newton steps of ``points`` (voxel coordinates) towards the ``level`` set of ``field``.

    Each step moves a point by :math:`-(\\phi - c) \\nabla\\phi / |\\nabla\\phi|^2`, at most
    ``max_step`` voxels; points where the gradient vanishes stay. ``level`` is a number or one per
    point.

    Returns
    -------
    (n, 3) float array
    """
    points = np.array(points, dtype=np.float64)
    level = np.broadcast_to(np.asarray(level, dtype=np.float64), (len(points),))
    for _ in range(iterations):
        checkpoint()  # an interrupt acts between iterations, not after the whole filter
        value, gradient = sample_field(field, points)
        norm2 = np.einsum("ij,ij->i", gradient, gradient)
        ok = norm2 > 1e-12
        step = np.zeros_like(points)
        step[ok] = -((value - level)[ok] / norm2[ok])[:, None] * gradient[ok]
        length = np.linalg.norm(step, axis=1)
        np.multiply(step, np.minimum(1.0, max_step / np.maximum(length, 1e-12))[:, None], out=step)
        points += step
    return points


def relax_on_field(points, faces, movable, field, iterations=20, level=0.0):
    """Spread the ``movable`` points (voxel coordinates) over the ``level`` set of ``field``.

    Each iteration moves every movable point to the mean of its neighbours within the plane normal
    to the field's gradient, then projects it back onto the level set; the other points hold still.
    ``level`` is a number or one per movable point.

    Returns
    -------
    (n, 3) float array
    """
    points = np.array(points, dtype=np.float64)
    index = np.flatnonzero(movable)
    if index.size == 0:
        return points
    average = vertex_adjacency(faces, len(points))[index]
    for _ in range(iterations):
        checkpoint()  # an interrupt acts between iterations, not after the whole filter
        target = average @ points
        _, gradient = sample_field(field, points[index])
        normal = gradient / np.maximum(np.linalg.norm(gradient, axis=1, keepdims=True), 1e-12)
        move = target - points[index]
        move -= normal * np.einsum("ij,ij->i", move, normal)[:, None]
        points[index] = project_onto_field(points[index] + move, field, iterations=2, level=level)
    return points


def folded_faces(vertices, faces, reference_normals):
    """Faces whose normal points against ``reference_normals`` or whose area vanished.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    reference_normals : (m, 3) float array
        The orientation each face should keep (e.g. the surface's outward normal there).

    Returns
    -------
    (m,) bool array
    """
    corners = vertices[faces]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    flipped = np.einsum("ij,ij->i", cross, reference_normals) <= 0
    return flipped | (area <= DEGENERATE_AREA * max(area.mean(), np.finfo(float).tiny))


def boundary_vertices(faces, n_vertices):
    """Vertices on an edge used by a single face (the rim of an open surface or of a hole)."""
    edges = np.sort(face_edges(np.asarray(faces, dtype=np.int64)), axis=1)
    codes, count = np.unique(edges[:, 0] * n_vertices + edges[:, 1], return_counts=True)
    single = codes[count == 1]
    out = np.zeros(n_vertices, dtype=bool)
    out[single // n_vertices] = True
    out[single % n_vertices] = True
    return out


def protruding(part, rest, share=0.6):
    """The connected components of ``part`` that stick out of ``rest`` into the third set.

    A removed bump sticks out of the kept shape into the air: most of its boundary (6-neighbour
    faces to voxels outside it) faces the air, its sides included. A layer of real surface that
    the pruning eroded is flush with the surface around it: its sides face kept material, and
    under half of its boundary faces the air. Components whose boundary faces the third set
    (neither ``part`` nor ``rest``) for at least ``share`` of its faces are returned. For dents,
    ``part`` is the added voxels and ``rest`` the background that stayed.

    Parameters
    ----------
    part, rest : bool arrays of one shape, disjoint

    Returns
    -------
    bool array
    """
    out = np.zeros_like(part)
    box = bounding_box(part, margin=1)
    if box is None:
        return out
    part, outside = part[box], ~(part[box] | rest[box])
    labels, count = ndimage.label(part)
    faces = np.zeros(count + 1)
    free = np.zeros(count + 1)
    for axis in range(3):
        lower = tuple(slice(0, -1) if a == axis else slice(None) for a in range(3))
        upper = tuple(slice(1, None) if a == axis else slice(None) for a in range(3))
        for here, there in ((lower, upper), (upper, lower)):
            border = part[here] & ~part[there]
            faces += np.bincount(labels[here][border], minlength=count + 1)
            free += np.bincount(labels[here][border & outside[there]], minlength=count + 1)
    keep = free >= share * np.maximum(faces, 1)
    keep[0] = False
    out[box] = keep[labels]
    return out


def grow(seed, allowed, faces, n_vertices):
    """``seed`` grown through the mesh's edges over the ``allowed`` vertices (hysteresis)."""
    adjacency = vertex_adjacency(faces, n_vertices)
    region = seed & allowed
    while True:
        grown = region | ((adjacency @ region.astype(np.float64)) > 0) & allowed
        if np.array_equal(grown, region):
            return region
        region = grown


def move_input_vertices(vertices, faces, mask, occupancy, field, input_field, grid, max_move, reach=2,
                        min_offset=2.0, weak_offset=0.5):
    """The input mesh's vertices (world) moved onto the denoised surface where the shape changed.

    Candidates are the vertices within ``reach`` voxels of a change that is noise: a removed bump
    or a filled dent that sticks out of the shape (`protruding`; the pruning also erodes real
    relief, which lies flush with the surface around it), that lie on the input's voxel surface
    (within ``reach`` of the occupancy's boundary, so parts of an open scan that the voxelization
    missed are left alone), are not on the mesh's boundary, and
    whose projection onto the denoised surface moves them at most ``max_move`` voxels. The voxel
    surfaces lie up to a voxel or so inside the mesh, so a vertex goes to the level of ``field``
    (the denoised shape's) that ``input_field`` (the input voxels', built alike) has at the vertex,
    and its offset is the difference of the two fields there. The vertices at least ``min_offset``
    voxels off (a removed bump, a filled dent: finer differences are the reconstruction's own
    rounding, left to the fine pass) move,
    with every candidate at least ``weak_offset`` off that connects to them through the mesh (the
    foot of a bump). The moved vertices are then spread over the surface by `relax_on_field`.

    Parameters
    ----------
    vertices : (n, 3) float array (world)
    faces : (m, 3) int array
    mask, occupancy : bool arrays over ``grid``: the denoised and the input voxels
    field, input_field : float arrays over ``grid``, > 0 inside the denoised and the input voxels
        (voxels; e.g. `skelfilter.mesh.marching_cubes.mask_field` for the input)
    grid : voxelize.Grid
    max_move, min_offset, weak_offset : float
        Voxels.

    Returns
    -------
    vertices : (n, 3) float array (world)
    moved : (n,) bool array
    """
    n = len(vertices)
    points = grid.to_index(vertices)
    voxel = np.clip(np.rint(points).astype(np.int64), 0, np.array(mask.shape) - 1)
    noise = protruding(occupancy & ~mask, mask) | protruding(mask & ~occupancy, ~mask)
    changed = dilated_by_cross(noise, reach)
    del noise
    rim = surface_voxels(occupancy)
    on_surface = dilated_by_cross(rim, reach)
    where = tuple(voxel.T)
    candidate = changed[where] & on_surface[where] & ~boundary_vertices(faces, n)
    moved = np.zeros(n, dtype=bool)
    index = np.flatnonzero(candidate)
    if index.size == 0:
        return vertices, moved
    level = sample_field(input_field, points[index])[0]
    offset = np.abs(sample_field(field, points[index])[0] - level)
    target = project_onto_field(points[index], field, level=level)
    reachable = np.linalg.norm(target - points[index], axis=1) <= max_move
    reachable &= np.abs(sample_field(field, target)[0] - level) < 0.5
    strong, weak = np.zeros(n, dtype=bool), np.zeros(n, dtype=bool)
    strong[index] = reachable & (offset >= min_offset)
    weak[index] = reachable & (offset >= weak_offset)
    moved = grow(strong, weak, faces, n)
    targets = np.zeros_like(points)
    targets[index] = target
    levels = np.zeros(n)
    levels[index] = level
    points[moved] = targets[moved]
    points = relax_on_field(points, faces, moved, field, level=levels[moved])
    return grid.to_world(points), moved


def unfold(vertices, faces, reference_normals, rounds=10):
    """Move the corners of `folded_faces` to the mean of their neighbours, until none is left.

    A fold is a local crumple (a face turned over by noise, or pressed flat onto its neighbours); a
    few uniform-Laplacian steps on its corners alone smooth it out and leave the rest untouched.

    Returns
    -------
    vertices : (n, 3) float array
    folded : int
        Faces still folded after ``rounds``.
    """
    vertices = np.array(vertices, dtype=np.float64)
    average = vertex_adjacency(faces, len(vertices))
    for _ in range(rounds):
        checkpoint()  # an interrupt acts between iterations, not after the whole filter
        folded = folded_faces(vertices, faces, reference_normals)
        if not folded.any():
            return vertices, 0
        corners = np.unique(faces[folded])
        vertices[corners] = average[corners] @ vertices
    return vertices, int(folded_faces(vertices, faces, reference_normals).sum())


def outward_normals(points, field):
    """Unit outward normals (−∇field) of a field that is > 0 inside, at voxel coordinates."""
    gradient = -sample_field(field, points)[1]
    return gradient / np.maximum(np.linalg.norm(gradient, axis=1, keepdims=True), 1e-12)
