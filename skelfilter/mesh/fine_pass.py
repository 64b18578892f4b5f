"""The fine pass: the noise below the skeleton's scale, smoothed on the mesh itself.

Fine two-sided noise (a scanner's, or what the voxel stage leaves at the scale of a voxel) is
removed at the input's own resolution, its strength set by the noise measured on the mesh
(`skelfilter.mesh.normal_filtering.normal_roughness`): the face normals are filtered, then the vertices
fitted to them. Two normal filters:

- ``bilateral`` (Zheng et al. 2011): `normal_filtering.bilateral_normals`, the first fine pass.
- ``adaptive`` (the default): the same, and where the cleaned surface is piecewise flat (its
  `guided_filtering.flat_share`), blended towards guided filtering (Zhang et al. 2015), which
  keeps creases sharp. Curved and coarsely tessellated surfaces, which the guidance of flat patches
  would facet, keep the bilateral filter's normals. Where the surface is confidently piecewise
  flat (a weight of 1), a few more rounds of guided filtering on the fitted mesh and fitting to
  it sharpen the creases further. Measured in ``docs/everyday-scans.md``.

References
----------
.. [1] Y. Zheng, H. Fu, O. K.-C. Au, C.-L. Tai, "Bilateral normal filtering for mesh denoising",
       IEEE TVCG 17(10), 2011.
.. [2] W. Zhang, B. Deng, J. Zhang, S. Bouaziz, L. Liu, "Guided mesh normal filtering", Computer
       Graphics Forum 34(7), 2015.
.. [3] X. Sun, P. L. Rosin, R. R. Martin, F. C. Langbein, "Fast and effective feature-preserving mesh
       denoising", IEEE TVCG 13(5), 2007.
"""

import numpy as np

from skelfilter.mesh import guided_filtering
from skelfilter.mesh.normal_filtering import (
    bilateral_normals,
    face_geometry,
    face_neighbours,
    fit_vertices,
    noise_correlation,
    normal_roughness,
    normalize,
    vertex_adjacency,
)

NORMAL_FILTERS = ("adaptive", "bilateral")
# The fine pass's settings at the two ends of the noise level (`normal_roughness`), linear in between:
# (noise level, sigma_r / noise level, normal iterations, vertex iterations). Light noise on organic
# shapes wants few iterations and a wide range kernel, heavy noise on flat faces many and a narrow one.
SCHEDULE = ((0.122, 4.5, 4, 4), (0.2, 2.5, 16, 10))
# Uniform-Laplacian steps of the low-pass that takes the drift out of the vertex displacement.
DRIFT_STEPS = 10
# Sensor noise: where the noise level reads under ``least_level`` (faces in flat pairs: a depth
# camera's terraces) and neighbouring vertices move alike (`noise_correlation` from CORRELATED_NOISE),
# the noise is a depth camera's waves over several vertices: it takes (sigma_r, normal iterations,
# vertex iterations) SENSOR_SCHEDULE and a gentler drift low-pass (SENSOR_DRIFT_STEPS), since the
# drift's ordinary low-pass would take back most of the waves' correction.
CORRELATED_NOISE = -0.04
SENSOR_SCHEDULE = (0.3, 20, 50)
SENSOR_DRIFT_STEPS = 100
# The narrowest range kernel: a clean mesh (noise level 0) only mixes parallel normals.
MIN_SIGMA_R = 1e-3
# `adaptive`: the weight of the guided normals rises from 0 to 1 as the flat share of the
# bilateral filter's normals goes from FLAT_SHARES[0] to FLAT_SHARES[1] (guided filtering sharpens
# piecewise-flat shapes and facets curved ones); the guided filter's range scale, iterations, and the
# vertex iterations it asks for.
FLAT_SHARES = (0.15, 0.25)
GUIDED_SIGMA_R = 0.35
GUIDED_ITERATIONS = 20
GUIDED_VERTEX_ITERATIONS = 10
# `adaptive` at a weight of 1: rounds of guided filtering (GUIDED_ROUND_ITERATIONS) of the fitted
# mesh's normals and fitting to them, as many as GUIDED_ROUNDS at the two ends of the noise level
# of SCHEDULE: they sharpen creases further. A round is refused, and the rounds end, where it would
# take the vertices farther from the input than ROUND_DISTANCE times the first fit did (RMS): it would
# then sharpen what is not a crease or facet a curved part.
GUIDED_ROUNDS = (2, 4)
GUIDED_ROUND_ITERATIONS = 10
ROUND_DISTANCE = 1.05


def _position(level):
    """Where a `normal_roughness` lies between the two ends of `SCHEDULE`, in [0, 1]."""
    (lo, *_), (hi, *_) = SCHEDULE
    return min(max((level - lo) / (hi - lo), 0.0), 1.0)


def schedule(level):
    """``(sigma_r, normal_iterations, vertex_iterations)`` for a `normal_roughness`."""
    (_, k_lo, n_lo, v_lo), (_, k_hi, n_hi, v_hi) = SCHEDULE
    t = _position(level)
    k = k_lo + t * (k_hi - k_lo)
    return max(k * level, MIN_SIGMA_R), int(round(n_lo + t * (n_hi - n_lo))), int(round(v_lo + t * (v_hi - v_lo)))


def guided_rounds(level):
    """The extra rounds of guided filtering and fitting for a `normal_roughness`, at a guided weight of 1."""
    lo, hi = GUIDED_ROUNDS
    return int(round(lo + _position(level) * (hi - lo)))


def _rms(displacement):
    return float(np.sqrt(np.mean(np.einsum("ij,ij->i", displacement, displacement))))


def guided_weight(flat):
    """The weight of the guided normals for a `guided_filtering.flat_share`, in [0, 1]."""
    lo, hi = FLAT_SHARES
    return min(max((flat - lo) / (hi - lo), 0.0), 1.0)


def fine_pass(vertices, faces, movable=None, normal_filter="adaptive", least_level=0.0):
    """Feature-preserving smoothing of a mesh's vertices, its strength set by the noise it measures.

    `bilateral_normals` with the `schedule` of the mesh's `normal_roughness`; with ``normal_filter``
    ``adaptive``, blended with `guided_filtering.guided_normals` by the `guided_weight` of the
    filtered normals' flat share; then `fit_vertices`; at a weight of 1, `guided_rounds` more rounds
    of guided filtering of the fitted mesh's normals and fitting to them, while they keep the vertices
    within `ROUND_DISTANCE` of the first fit's distance from the input. Fitting vertices to the planes of their faces
    pulls curved parts inwards (each vertex of a convex part lies above its faces' centroids); that
    drift is smooth while the noise is not, so the low-pass of the displacement (`DRIFT_STEPS`
    uniform-Laplacian steps) is taken back out.

    Parameters
    ----------
    vertices : (n, 3) float array
    faces : (m, 3) int array
    movable : (n,) bool array, optional
        Vertices allowed to move.
    normal_filter : {'adaptive', 'bilateral'}
    least_level : float, optional
        The `normal_roughness` to smooth as at least (a mesh whose faces come in flat pairs, a depth
        camera's terraces, measures less noise than it carries); where the level reads under it and
        the noise is correlated, `SENSOR_SCHEDULE`.

    Returns
    -------
    vertices : (n, 3) float array
        The moved vertices (the faces are unchanged).
    normals : (m, 3) float array
        The filtered face normals the vertices were fitted to.

    References
    ----------
    .. [1] Y. Zheng, H. Fu, O. K.-C. Au, C.-L. Tai, "Bilateral normal filtering for mesh denoising",
           IEEE TVCG 17(10), 2011.
    .. [2] W. Zhang, B. Deng, J. Zhang, S. Bouaziz, L. Liu, "Guided mesh normal filtering",
           Computer Graphics Forum 34(7), 2015.
    """
    if normal_filter not in NORMAL_FILTERS:
        raise ValueError(f"normal_filter must be one of {', '.join(NORMAL_FILTERS)}, got {normal_filter!r}")
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    normals, areas, centroids = face_geometry(vertices, faces)
    pairs = face_neighbours(faces, len(vertices))
    measured = normal_roughness(normals, pairs)
    level = max(measured, least_level)
    sigma_r, normal_iterations, vertex_iterations = schedule(level)
    drift_steps = DRIFT_STEPS
    if measured < least_level and noise_correlation(vertices, faces) >= CORRELATED_NOISE:
        (sigma_r, normal_iterations, vertex_iterations), drift_steps = SENSOR_SCHEDULE, SENSOR_DRIFT_STEPS
    filtered = bilateral_normals(normals, areas, centroids, pairs, sigma_r, normal_iterations)
    weight = 0.0
    if normal_filter == "adaptive":
        across = guided_filtering.edge_neighbours(faces)
        neighbours = guided_filtering.neighbour_lists(pairs, len(faces))
        weight = guided_weight(guided_filtering.flat_share(filtered, areas, neighbours, across))
        if weight > 0:
            guided = guided_filtering.guided_normals(normals, areas, centroids, pairs, across, GUIDED_SIGMA_R,
                                                     GUIDED_ITERATIONS)
            filtered = normalize(weight * guided + (1.0 - weight) * filtered)
            vertex_iterations = int(round(vertex_iterations
                                          + weight * max(0, GUIDED_VERTEX_ITERATIONS - vertex_iterations)))
    moved = fit_vertices(vertices, faces, filtered, vertex_iterations, movable)
    if weight == 1.0:
        reach = ROUND_DISTANCE * _rms(moved - vertices)
        for _ in range(guided_rounds(level)):
            current, current_areas, current_centroids = face_geometry(moved, faces)
            target = guided_filtering.guided_normals(current, current_areas, current_centroids, pairs, across,
                                                     GUIDED_SIGMA_R, GUIDED_ROUND_ITERATIONS)
            candidate = fit_vertices(moved, faces, target, vertex_iterations, movable)
            if _rms(candidate - vertices) > reach:
                break
            moved, filtered = candidate, target
    average = vertex_adjacency(faces, len(vertices))
    drift = moved - vertices
    for _ in range(drift_steps):
        drift = average @ drift
    if movable is not None:
        drift[~movable] = 0.0
    return moved - drift, filtered
