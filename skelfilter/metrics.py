"""Error measures: the thesis' own (eq. 4.17, 4.18, 6.5, 7.23, 7.24) and mesh-level ones.

Voxel-set measures take either flat indices into a C-ordered volume (the
convention of `skelfilter.neighbourhood`) or boolean volumes; both
arguments must refer to volumes of the same shape.

Mesh measures compare a result mesh with the clean mesh and report
distances in voxels of a given `skelfilter.voxelize.Grid` (world distances
divided by ``grid.pitch``). Closest-point distances are exact
point-to-surface distances from open3d's ray-casting scene (Embree), taken
at area-uniform samples drawn with a fixed seed, so every measure is
deterministic.
"""

import numpy as np
import trimesh
from scipy import ndimage

from .closest_points import MeshSurface
from .errors import InputError, ParameterError
from .voxelize import voxelize_on_grid

# Points drawn on each surface for the distance measures.
N_SAMPLES = 100_000
SEED = 0


# --------------------------------------------------------------------------
# Voxel-set measures (thesis eq. 4.17, 4.18, 6.5)
# --------------------------------------------------------------------------


def _as_flat(voxels):
    """Sorted unique flat indices of a voxel set given as flat indices or a boolean volume."""
    a = np.asarray(voxels)
    if a.dtype == bool:
        return np.flatnonzero(a.reshape(-1)).astype(np.int64)
    if a.size and not np.issubdtype(a.dtype, np.integer):
        raise ParameterError(f"a voxel set must be flat integer indices or a boolean volume, got dtype {a.dtype}")
    return np.unique(a.reshape(-1).astype(np.int64))


def _jaccard_error(a, b):
    a, b = _as_flat(a), _as_flat(b)
    union = np.union1d(a, b).size
    if union == 0:
        return float("nan")
    return 1.0 - np.intersect1d(a, b, assume_unique=True).size / union


def skeleton_error(regularized, original):
    """Total skeleton error ``epsilon`` (thesis eq. 4.17).

    .. math:: \\epsilon = 1 - |S_{v(t)} \\cap S| / |S_{v(t)} \\cup S|

    Parameters
    ----------
    regularized : array_like
        ``S_{v(t)}``: flat int indices or a boolean volume.
    original : array_like
        ``S``: flat int indices or a boolean volume of the same shape.

    Returns
    -------
    float
        In [0, 1]; NaN when both sets are empty (0 / 0).
    """
    return _jaccard_error(regularized, original)


def skeleton_false_positive_rate(regularized, original):
    """False-positive rate ``nu`` of a regularized skeleton (thesis eq. 4.18).

    .. math:: \\nu = |S_{v(t)} \\setminus S| / |S_{v(t)}|

    Parameters
    ----------
    regularized : array_like
        ``S_{v(t)}``: flat int indices or a boolean volume.
    original : array_like
        ``S``: flat int indices or a boolean volume of the same shape.

    Returns
    -------
    float
        In [0, 1]; NaN when ``regularized`` is empty (0 / 0).
    """
    a, b = _as_flat(regularized), _as_flat(original)
    if a.size == 0:
        return float("nan")
    return np.setdiff1d(a, b, assume_unique=True).size / a.size


def reconstruction_error(reconstruction, original):
    """Reconstruction error ``epsilon_hat`` (thesis eq. 6.5, corrected).

    .. math:: \\hat\\epsilon = 1 - |R(S_{v(t)}) \\cap X| / |R(S_{v(t)}) \\cup X|

    As printed, eq. 6.5 has ``|S_{v(t)} \\cup X|`` in the denominator; the
    text calls it eq. 4.17 applied to reconstructions, so the union is taken
    with the reconstruction ``R(S_{v(t)})`` (see READING-NOTES.md).

    Parameters
    ----------
    reconstruction : array_like
        ``R(S_{v(t)})``: flat int indices or a boolean volume.
    original : array_like
        ``X``, the clean model: flat int indices or a boolean volume of the same shape.

    Returns
    -------
    float
        In [0, 1]; NaN when both sets are empty.
    """
    return _jaccard_error(reconstruction, original)


# --------------------------------------------------------------------------
# Geodesic estimate (thesis eq. 7.23, 7.24)
# --------------------------------------------------------------------------


def geodesic_errors(rho, rho_est):
    """Mean and maximum relative error of a geodesic estimate (thesis eq. 7.23, 7.24).

    .. math::
        \\epsilon = \\frac{1}{|S|} \\sum_{x \\in S} \\frac{|\\rho(x) - \\rho_{est}(x)|}{\\rho(x)},
        \\qquad
        m = \\max_{x \\in S} \\frac{|\\rho(x) - \\rho_{est}(x)|}{\\rho(x)}

    Parameters
    ----------
    rho : array_like of float
        Ground-truth (graph) geodesic lengths over the skeleton ``S``; all > 0.
    rho_est : array_like of float
        Estimated lengths, aligned with ``rho``.

    Returns
    -------
    epsilon : float
        Mean relative error (eq. 7.23); NaN for an empty skeleton.
    m : float
        Maximum relative error (eq. 7.24); NaN for an empty skeleton.

    Raises
    ------
    ParameterError
        If the shapes differ, or ``rho`` has values that are not finite and positive.
    """
    rho = np.asarray(rho, dtype=np.float64).reshape(-1)
    est = np.asarray(rho_est, dtype=np.float64).reshape(-1)
    if rho.shape != est.shape:
        raise ParameterError(f"rho and rho_est must have the same size, got {rho.size} and {est.size}")
    if rho.size == 0:
        return float("nan"), float("nan")
    if not (np.isfinite(rho).all() and (rho > 0).all()):
        raise ParameterError("rho must be finite and > 0 (it divides the errors)")
    rel = np.abs(rho - est) / rho
    return float(rel.mean()), float(rel.max())


# --------------------------------------------------------------------------
# Surface distances
# --------------------------------------------------------------------------


def pass_through(result, source, quantile=99.0):
    """How far a result lies from its source mesh: the ``quantile`` percentile of the distances from
    the source's vertices to the result's surface and from the result's vertices to the source's,
    each over the source's bounding-box diagonal, and the relative change of the enclosed volume
    (of the meshes when both are closed, else NaN).

    Returns
    -------
    dict
        ``source_to_result``, ``result_to_source`` (fractions of the diagonal), ``volume_change``.
    """
    diagonal = float(np.linalg.norm(np.ptp(np.asarray(source.vertices), axis=0)))
    there = MeshSurface(result).closest(source.vertices)[0]
    back = MeshSurface(source).closest(result.vertices)[0]
    volume = float("nan")
    if source.is_volume and result.is_volume:
        volume = float(abs(result.volume - source.volume) / abs(source.volume))
    return {"source_to_result": float(np.percentile(there, quantile) / diagonal),
            "result_to_source": float(np.percentile(back, quantile) / diagonal), "volume_change": volume}


def _sample(mesh, n, seed):
    """``n`` area-uniform points on the mesh with a fixed seed, and their faces."""
    points, faces = trimesh.sample.sample_surface(mesh, int(n), seed=seed)
    return np.asarray(points, dtype=np.float64), np.asarray(faces, dtype=np.int64)


def _directed(a_points, b_surface, pitch):
    return b_surface.closest(a_points)[0] / pitch


def _distances(result, clean, grid, n_samples, seed, surfaces=None):
    """Directed distances (voxels) result→clean and clean→result at area-uniform samples."""
    rs, cs = surfaces if surfaces is not None else (MeshSurface(result), MeshSurface(clean))
    r_pts, _ = _sample(result, n_samples, seed + 1)
    c_pts, _ = _sample(clean, n_samples, seed + 1)
    return _directed(r_pts, cs, grid.pitch), _directed(c_pts, rs, grid.pitch)


def chamfer_distance(result, clean, grid, n_samples=N_SAMPLES, seed=SEED):
    """Symmetric Chamfer distance between two surfaces, in voxels.

    .. math:: C = \\tfrac12 \\left( \\overline{d}(A \\to B) + \\overline{d}(B \\to A) \\right)

    where :math:`\\overline{d}(A \\to B)` is the mean, over ``n_samples``
    area-uniform points of ``A``'s surface (fixed ``seed``), of their
    point-to-surface distance to ``B``. Distances are not squared.

    Parameters
    ----------
    result, clean : trimesh.Trimesh
    grid : voxelize.Grid
        Distances are divided by ``grid.pitch``.
    n_samples : int, optional
        Points drawn on each surface (also the density of the target samples).
    seed : int, optional

    Returns
    -------
    float
    """
    return surface_distances(result, clean, grid, n_samples, seed)[0]


def hausdorff_distance(result, clean, grid, n_samples=N_SAMPLES, seed=SEED):
    """Symmetric Hausdorff distance (max) and its 95th-percentile variant, in voxels.

    Both are the larger of the two directed values over area-uniform surface
    samples: ``max(q(d(A->B)), q(d(B->A)))`` with ``q`` the maximum or the
    95th percentile.

    Parameters
    ----------
    result, clean : trimesh.Trimesh
    grid : voxelize.Grid
    n_samples : int, optional
    seed : int, optional

    Returns
    -------
    h95 : float
    hmax : float
    """
    return surface_distances(result, clean, grid, n_samples, seed)[1:]


def surface_distances(result, clean, grid, n_samples=N_SAMPLES, seed=SEED, surfaces=None):
    """Chamfer distance, Hausdorff 95 % and Hausdorff max (voxels) from one set of samples.

    See `chamfer_distance` and `hausdorff_distance`; ``surfaces`` reuses prepared
    ``(result, clean)`` closest-point scenes.

    Returns
    -------
    chamfer, h95, hmax : float
    """
    d_rc, d_cr = _distances(result, clean, grid, n_samples, seed, surfaces)
    h95 = max(float(np.percentile(d_rc, 95)), float(np.percentile(d_cr, 95)))
    return 0.5 * (float(d_rc.mean()) + float(d_cr.mean())), h95, max(float(d_rc.max()), float(d_cr.max()))


def normal_error(result, clean, clean_surface=None):
    """Area-weighted mean angle (degrees) between result face normals and the closest clean face's normal.

    For each face of ``result``, its normal is compared with the normal of the
    clean face closest to its centroid; angles are weighted by the result
    faces' areas. Orientation matters (a flipped face counts 180 degrees).

    Parameters
    ----------
    result, clean : trimesh.Trimesh

    Returns
    -------
    float
        In [0, 180]; NaN when ``result`` has zero total area.
    """
    cs = clean_surface if clean_surface is not None else MeshSurface(clean)
    _, face = cs.closest(result.triangles_center)
    cos = np.einsum("ij,ij->i", result.face_normals, clean.face_normals[face])
    angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    area = result.area_faces
    if area.sum() <= 0:
        return float("nan")
    return float(np.average(angle, weights=area))


def literature_errors(result, clean):
    """The mesh-denoising field's two scores: mean face-normal angle and E_v.

    The angle is `normal_error` (degrees; each result face against the clean face closest to its
    centroid, weighted by the result faces' areas); E_v is the area-weighted RMS distance from the
    result's vertices to the clean surface (a vertex weighs a third of the area of its faces),
    divided by the clean mesh's mean edge length. On the noisy inputs of ``shared/data/literature``
    both reproduce the figures its README quotes.

    Parameters
    ----------
    result, clean : trimesh.Trimesh

    Returns
    -------
    angle_deg, e_v : float

    References
    ----------
    .. [1] Zhang, W., Deng, B., Zhang, J., Bouaziz, S., Liu, L. "Guided Mesh Normal Filtering".
       Computer Graphics Forum 34(7), 2015 (the metrics of its section 6).
    """
    cs = MeshSurface(clean)
    weight = np.zeros(len(result.vertices))
    np.add.at(weight, result.faces.reshape(-1), np.repeat(result.area_faces / 3.0, 3))
    distance = cs.closest(result.vertices)[0]
    e_v = float(np.sqrt(np.sum(weight * distance**2) / weight.sum()))
    return normal_error(result, clean, cs), e_v / float(clean.edges_unique_length.mean())


def sharp_edges(mesh, angle=30.0):
    """Vertex pairs of the edges whose two faces' normals differ by more than ``angle`` degrees."""
    return mesh.face_adjacency_edges[mesh.face_adjacency_angles > np.radians(angle)]


def vertex_distances(result, clean, grid):
    """Distance (voxels) from every vertex of ``result`` to the clean surface, for colour maps."""
    return MeshSurface(clean).closest(result.vertices)[0] / grid.pitch


def sharp_edge_error(result, clean, grid, angle=30.0, spacing=0.5, result_surface=None):
    """Distance (voxels) from points along the clean mesh's sharp edges to the result surface.

    Sharp edges are the clean mesh's edges shared by two faces whose normals
    differ by more than ``angle`` degrees (`trimesh.Trimesh.face_adjacency_angles`).
    Each is sampled every ``spacing`` voxels, end points included.

    Parameters
    ----------
    result, clean : trimesh.Trimesh
    grid : voxelize.Grid
    angle : float, optional
        Dihedral threshold in degrees.
    spacing : float, optional
        Sampling step along the edges, in voxels.

    Returns
    -------
    mean : float
        NaN when the clean mesh has no sharp edge.
    max : float
        NaN when the clean mesh has no sharp edge.
    n_edges : int
        Number of sharp edges found.
    """
    edges = sharp_edges(clean, angle)
    if len(edges) == 0:
        return float("nan"), float("nan"), 0
    a, b = clean.vertices[edges[:, 0]], clean.vertices[edges[:, 1]]
    length = np.linalg.norm(b - a, axis=1) / grid.pitch
    count = np.ceil(length / spacing).astype(np.int64) + 1  # points per edge
    owner = np.repeat(np.arange(len(edges)), count)
    start = np.cumsum(count) - count
    t = (np.arange(owner.size) - start[owner]) / np.maximum(count[owner] - 1, 1)
    points = a[owner] + t[:, None] * (b - a)[owner]
    rs = result_surface if result_surface is not None else MeshSurface(result)
    d = rs.closest(points)[0] / grid.pitch
    return float(d.mean()), float(d.max()), int(len(edges))


# --------------------------------------------------------------------------
# Volumetric measures
# --------------------------------------------------------------------------


def volumetric_iou(result, clean, grid):
    """Intersection over union of the two meshes' voxelizations on ``grid``.

    Both are voxelized with `skelfilter.voxelize.voxelize_on_grid`.

    Returns
    -------
    float
        ``|V(result) ∩ V(clean)| / |V(result) ∪ V(clean)|``; NaN when both are empty.
    """
    return _iou(voxelize_on_grid(result, grid), voxelize_on_grid(clean, grid))


def _iou(a, b):
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
        (e.g. `skelfilter.noise.NoiseResult`).
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


# --------------------------------------------------------------------------
# Topology
# --------------------------------------------------------------------------


def is_edge_manifold(mesh):
    """True when every (undirected) edge of ``mesh`` is used by at most two faces.

    Edges are vertex-index pairs as stored: merge vertices first to judge the geometry.
    """
    if len(mesh.faces) == 0:
        return True
    _, counts = np.unique(mesh.edges_sorted, axis=0, return_counts=True)
    return bool(counts.max() <= 2)


# --------------------------------------------------------------------------
# Everything at once
# --------------------------------------------------------------------------


def _invalid(mesh):
    """Why a mesh cannot be measured, or None."""
    if not isinstance(mesh, trimesh.Trimesh):
        return f"not a triangle mesh: {type(mesh).__name__}"
    if len(mesh.faces) == 0:
        return "the mesh has no faces"
    if not np.isfinite(mesh.vertices).all():
        return "the mesh has non-finite vertex coordinates"
    if not mesh.area > 0:
        return "the mesh has zero surface area"
    return None


def mesh_metrics(result, clean, grid, noise=None, reach=6.1, sharp_angle=30.0, n_samples=N_SAMPLES, seed=SEED):
    """All mesh-level measures of a result against the clean mesh.

    Parameters
    ----------
    result : trimesh.Trimesh
        The denoised mesh.
    clean : trimesh.Trimesh
        The ground truth.
    grid : voxelize.Grid
        Unit of the distances (``grid.pitch``) and grid of the volumetric measures.
    noise : NoiseResult-like, optional
        Boolean ``bumps``/``dents`` volumes on ``grid``; enables the noise
        measures and restricts ``shrinkage`` to voxels away from the noise.
    reach : float, optional
        See `shrinkage`.
    sharp_angle : float, optional
        Dihedral threshold (degrees) of the clean mesh's sharp edges.
    n_samples : int, optional
        Surface samples per mesh for the distance measures.
    seed : int, optional

    Returns
    -------
    dict
        ``chamfer``, ``hausdorff_95``, ``hausdorff_max`` (voxels),
        ``normal_error_deg``, ``iou``, ``shrinkage``, ``sharp_edge_mean``,
        ``sharp_edge_max`` (voxels), ``sharp_edges`` (count), ``watertight``,
        ``edge_manifold``, ``faces``, and with ``noise`` also
        ``noise_removed``, ``bumps_removed``, ``dents_removed``. When the
        result has no faces, non-finite vertices or zero area, only
        ``{"error": reason, "faces": n}`` is returned instead of raising.

    Raises
    ------
    InputError
        If the clean mesh itself cannot be measured.
    """
    why = _invalid(clean)
    if why:
        raise InputError(f"clean mesh: {why}")
    why = _invalid(result)
    if why:
        faces = len(result.faces) if isinstance(result, trimesh.Trimesh) else 0
        return {"error": why, "faces": faces}

    rs, cs = MeshSurface(result), MeshSurface(clean)
    chamfer, h95, hmax = surface_distances(result, clean, grid, n_samples, seed, surfaces=(rs, cs))
    v_result, v_clean = voxelize_on_grid(result, grid), voxelize_on_grid(clean, grid)
    sharp_mean, sharp_max, n_sharp = sharp_edge_error(result, clean, grid, sharp_angle, result_surface=rs)
    out = {
        "chamfer": chamfer,
        "hausdorff_95": h95,
        "hausdorff_max": hmax,
        "normal_error_deg": normal_error(result, clean, clean_surface=cs),
        "iou": _iou(v_result, v_clean),
        "shrinkage": shrinkage(result, clean, grid, noise, reach, v_result, v_clean),
        "sharp_edge_mean": sharp_mean,
        "sharp_edge_max": sharp_max,
        "sharp_edges": n_sharp,
        "watertight": bool(result.is_watertight),
        "edge_manifold": is_edge_manifold(result),
        "faces": int(len(result.faces)),
    }
    if noise is not None:
        out.update(noise_removed(result, noise, grid, v_result))
    return out


# --------------------------------------------------------------------------
# Genus
# --------------------------------------------------------------------------

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
        from .voxelize import grid_for_bounds

        grid = grid if grid is not None else grid_for_bounds(mesh.bounds, GENUS_RESOLUTION, 2)
        volume = voxelize_on_grid(mesh, grid)
    return voxel_genus(volume)
