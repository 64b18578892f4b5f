"""Error measures: the thesis' own (eq. 4.17, 4.18, 6.5, 7.23, 7.24) and mesh-level ones, one
module per kind; every public measure is importable from here.

:mod:`~.thesis_measures` (voxel sets, geodesic estimates), :mod:`~.surface_distances` (Chamfer,
Hausdorff, normals, sharp edges, the literature's θ and E_v), :mod:`~.volumetric` (IoU, noise
removed, shrinkage, thin parts), :mod:`~.topology` (manifoldness, genus), :mod:`~.reference_free`
(roughness, volume change: no clean mesh needed) and :mod:`~.mesh_metrics` (all of a result's mesh
measures at once).
"""

from skelfilter.evaluation.metrics.mesh_metrics import change_measures, mesh_metrics
from skelfilter.evaluation.metrics.reference_free import roughness, volume_change
from skelfilter.evaluation.metrics.surface_distances import (
    N_SAMPLES,
    SEED,
    LiteratureScores,
    chamfer_distance,
    hausdorff_distance,
    literature_errors,
    literature_normal_error,
    normal_error,
    pass_through,
    sharp_edge_error,
    sharp_edges,
    surface_distances,
    vertex_distances,
)
from skelfilter.evaluation.metrics.thesis_measures import (
    geodesic_errors,
    reconstruction_error,
    skeleton_error,
    skeleton_false_positive_rate,
)
from skelfilter.evaluation.metrics.topology import (
    GENUS_RESOLUTION,
    closed_manifold_genus,
    genus,
    is_edge_manifold,
    voxel_genus,
)
from skelfilter.evaluation.metrics.volumetric import (
    concavities,
    concavity_filled,
    noise_removed,
    shrinkage,
    thickness_under,
    thin_parts,
    thin_parts_kept,
    volumetric_iou,
)

__all__ = [
    "GENUS_RESOLUTION", "N_SAMPLES", "SEED", "LiteratureScores", "chamfer_distance", "change_measures",
    "closed_manifold_genus", "concavities", "concavity_filled", "genus", "geodesic_errors",
    "hausdorff_distance", "is_edge_manifold", "literature_errors", "literature_normal_error", "mesh_metrics",
    "noise_removed", "normal_error", "pass_through", "reconstruction_error", "roughness", "sharp_edge_error",
    "sharp_edges", "shrinkage", "skeleton_error", "skeleton_false_positive_rate", "surface_distances",
    "thickness_under", "thin_parts", "thin_parts_kept", "vertex_distances", "volume_change", "volumetric_iou",
    "voxel_genus",
]
