"""skelfilter: feature-preserving mesh denoising by surface-skeleton saliency pruning.

The pipeline of the master thesis "Salient edge preserving noise removal using surface skeletons"
(§8.1.1). Data flows one way, and so do the imports: each layer imports only those above it here::

    errors, params       the errors and the one table of parameters
    runtime              progress, signals, memory, child processes, optional extras
    core   | io          the thesis' stages on arrays (distance -> skeleton -> importance ->
                         saliency -> edt_filters -> reconstruct, the volume pipeline) | files
    mesh                 voxelize -> core -> marching cubes or the input's vertices moved
    meshlab              filter descriptions, .mlx scripts, pymeshlab, MeshSet
    evaluation | jobs    metrics, figures, the comparison | one file, many files on Dask
    demo, cli            entry points

Entry points: :func:`denoise_mesh`, :func:`denoise_volume`, :func:`noisy_mesh`
and :func:`add_noise`; :func:`denoise_file` (a mesh, volume or point-cloud file) and
:func:`denoise_many` (many files on Dask); every stage is a public function of its module and is
re-exported here. The MeshLab side: :mod:`skelfilter.meshlab.meshset` (the filters on a
PyMeshLab MeshSet) and :mod:`skelfilter.meshlab.scripts` (.mlx filter scripts).
"""

import importlib

# Public names and the module each lives in; modules load on first use so
# ``import skelfilter`` stays cheap (numba kernels compile or load lazily).
_EXPORTS = {
    "core.distance": ["distance_and_features", "distance_transform"],
    "core.edt_filters": ["filtered_radii", "flat_projection", "kernel_filter", "least_squares", "minify"],
    "errors": ["InputError", "ParameterError", "ResourceError", "SkelfilterError"],
    "core.importance": ["boundary_layer", "euclidean_importance", "geodesic_estimate", "geodesic_importance"],
    "core.synthetic_noise": ["NoiseResult", "add_noise"],
    "params": ["DenoiseParams", "NoiseParams"],
    "core.pipeline": ["DenoiseResult", "denoise_volume"],
    "mesh.pipeline": ["denoise_mesh", "denoise_mesh_detailed", "noisy_mesh"],
    "core.reconstruct": ["reconstruction", "reverse_edt", "signed_distance"],
    "core.saliency": ["derivative_measure", "direct_rho_plus", "edt_gradient_velocity", "feature_velocity",
                      "importance_gradient_velocity", "rho_plus", "skeleton_adjacency"],
    "core.selection": ["root_component", "saliency_measure"],
    "core.skeleton": ["extended_feature_points", "ie_skeleton", "ima_skeleton"],
    "mesh.marching_cubes": ["field_to_mesh", "field_to_world_mesh", "mask_to_mesh"],
    "jobs.denoise_file": ["denoise_file"],
    "jobs.batch": ["denoise_many"],
    "io.volume_files": ["load_volume", "save_volume"],
    "mesh.voxelize": ["Grid", "voxelize_on_grid"],
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}


def __getattr__(name):
    if name in _WHERE:
        return getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
    raise AttributeError(f"module 'skelfilter' has no attribute {name!r}")


__version__ = "0.1.0"

__all__ = sorted(_WHERE)
