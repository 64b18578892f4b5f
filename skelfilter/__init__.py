"""skelfilter: feature-preserving mesh denoising by surface-skeleton saliency pruning.

The pipeline of the master thesis "Salient edge preserving noise removal using surface skeletons"
(§8.1.1), one module per stage::

    voxelize -> distance -> skeleton -> importance -> saliency -> edt_filters
             -> reconstruct -> surface

Entry points: :func:`denoise_mesh`, :func:`denoise_volume`, :func:`noisy_mesh`
and :func:`add_noise`; :func:`denoise_file` (a mesh, volume or point-cloud file) and
:func:`denoise_many` (many files on Dask); every stage is a public function of its module and is
re-exported here. The MeshLab side: :mod:`skelfilter.meshset` (the filters on a
PyMeshLab MeshSet) and :mod:`skelfilter.meshlab` (.mlx filter scripts).
"""

import importlib

# Public names and the module each lives in; modules load on first use so
# ``import skelfilter`` stays cheap (numba kernels compile or load lazily).
_EXPORTS = {
    "distance": ["distance_and_features"],
    "edt_filters": ["minify"],
    "errors": ["InputError", "ParameterError", "ResourceError", "SkelfilterError"],
    "importance": ["boundary_layer", "euclidean_importance", "geodesic_estimate", "geodesic_importance"],
    "noise": ["NoiseResult", "add_noise"],
    "params": ["DenoiseParams", "NoiseParams"],
    "pipeline": ["DenoiseResult", "denoise_volume"],
    "mesh_pipeline": ["denoise_mesh", "denoise_mesh_detailed", "noisy_mesh"],
    "reconstruct": ["reconstruction", "reverse_edt", "signed_distance"],
    "saliency": ["derivative_measure", "edt_gradient_velocity", "feature_velocity", "rho_plus",
                 "skeleton_adjacency"],
    "skeleton": ["extended_feature_points", "ie_skeleton", "ima_skeleton"],
    "surface": ["field_to_mesh", "field_to_world_mesh", "mask_to_mesh"],
    "files": ["denoise_file"],
    "batch": ["denoise_many"],
    "volume_io": ["load_volume", "save_volume"],
    "voxelize": ["Grid", "voxelize_on_grid"],
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}


def __getattr__(name):
    if name in _WHERE:
        return getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
    raise AttributeError(f"module 'skelfilter' has no attribute {name!r}")


__version__ = "0.1.0"

__all__ = sorted(_WHERE)
