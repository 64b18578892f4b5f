"""Topology: edge-manifoldness and the genus of a mesh or a voxel volume.
"""

import numpy as np
import trimesh
from scipy import ndimage

from skelfilter.mesh.voxelize import voxelize_on_grid


def is_edge_manifold(mesh):
    """True when every (undirected) edge of ``mesh`` is used by at most two faces.

    Edges are vertex-index pairs as stored: merge vertices first to judge the geometry.
    """
    if len(mesh.faces) == 0:
        return True
    _, counts = np.unique(mesh.edges_sorted, axis=0, return_counts=True)
    return bool(counts.max() <= 2)



# Voxels along the longest side when `genus` has to voxelize a mesh on a grid of its own.
GENUS_RESOLUTION = 256


def closed_manifold_genus(mesh):
    """Genus and number of surfaces of a closed 2-manifold mesh, from its Euler characteristic.

    Vertices at the same position are merged first. The mesh is a closed
    manifold when every edge has exactly two faces and the faces around each
    vertex form one fan (no two cones meeting at a vertex). Then, with
    ``C`` connected surfaces and ``chi = V - E + F``, the total genus is
    ``(2 C - chi) / 2`` (each closed orientable surface has ``chi = 2 - 2 g``).

    Parameters
    ----------
    mesh : trimesh.Trimesh

    Returns
    -------
    dict or None
        ``{"genus": g, "components": C, "from": "mesh"}``, or None when the
        merged mesh is not a closed manifold.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    merged = trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), process=False)
    merged.merge_vertices()
    faces = merged.faces
    if len(faces) == 0 or (faces == np.roll(faces, 1, axis=1)).any():
        return None
    _, counts = np.unique(merged.edges_sorted, axis=0, return_counts=True)
    if (counts != 2).any():
        return None
    pairs, shared = merged.face_adjacency, merged.face_adjacency_edges
    # Corners 3 f + k; the two corners of a vertex in two faces sharing one of its edges are linked:
    # a vertex is manifold when its corners form a single cycle (one fan).
    links = [3 * pairs[:, side] + np.argmax(faces[pairs[:, side]] == shared[:, [end]], axis=1)
             for end in (0, 1) for side in (0, 1)]
    rows, cols = np.concatenate(links[0::2]), np.concatenate(links[1::2])
    n_corners = 3 * len(faces)
    fans = connected_components(coo_matrix((np.ones(rows.size), (rows, cols)), shape=(n_corners,) * 2),
                                directed=False)[0]
    n_vertices = np.unique(faces).size
    if fans != n_vertices:
        return None
    surfaces = connected_components(
        coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(len(faces),) * 2), directed=False)[0]
    chi = n_vertices - len(counts) + len(faces)
    return {"genus": int((2 * surfaces - chi) // 2), "components": int(surfaces), "from": "mesh"}


def voxel_genus(volume):
    """Genus and number of boundary surfaces of a voxel solid (26-connected; background 6-connected).

    With ``b0`` solid components, ``c`` cavities (background components not
    reaching the volume's border) and the Euler number ``chi = b0 - b1 + c``
    of the solid (`skimage.measure.euler_number`, 26-connectivity), the
    tunnels ``b1 = b0 + c - chi`` equal the total genus of the boundary
    surfaces (for a solid in space, H1 of the solid has half the rank of H1
    of its boundary), and the boundary has ``b0 + c`` surfaces.

    Parameters
    ----------
    volume : (nx, ny, nz) array_like of bool

    Returns
    -------
    dict
        ``{"genus": g, "components": b0 + c, "from": "voxels"}``.
    """
    from skimage.measure import euler_number

    solid = np.pad(np.asarray(volume, dtype=bool), 1)
    pieces = ndimage.label(solid, structure=np.ones((3, 3, 3)))[1]
    cavities = ndimage.label(~solid)[1] - 1
    chi = euler_number(solid, connectivity=3)
    return {"genus": int(pieces + cavities - chi), "components": int(pieces + cavities), "from": "voxels"}


def genus(mesh, grid=None, volume=None):
    """Genus (through holes) and surface count of a mesh.

    From the Euler characteristic (`closed_manifold_genus`) when the mesh
    is a closed manifold, otherwise from its voxelization (`voxel_genus`).

    Parameters
    ----------
    mesh : trimesh.Trimesh
    grid : voxelize.Grid, optional
        Grid of the voxelization; by default one of ``GENUS_RESOLUTION``
        voxels along the mesh's longest side.
    volume : ndarray of bool, optional
        The mesh's voxelization when already known.

    Returns
    -------
    dict
        ``genus``, ``components`` and ``from`` (``"mesh"`` or ``"voxels"``).
    """
    found = closed_manifold_genus(mesh)
    if found is not None:
        return found
    if volume is None:
        from skelfilter.mesh.voxelize import grid_for_bounds

        grid = grid if grid is not None else grid_for_bounds(mesh.bounds, GENUS_RESOLUTION, 2)
        volume = voxelize_on_grid(mesh, grid)
    return voxel_genus(volume)
