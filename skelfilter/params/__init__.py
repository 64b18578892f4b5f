"""The filter parameters, in one place.

Every parameter is a dataclass field whose metadata carries what MeshLab shows
of a filter parameter: a short label, a description (the tooltip and the CLI
help), its unit, its choices and, for lengths and thresholds, whether the value
is absolute (voxels) or relative to the model's size. :mod:`skelfilter.meshlab.descriptions`
builds the MeshLab-style filter descriptions from these dataclasses, and the CLI
flags, the Python and MeshSet defaults, the .mlx scripts and ``docs/filters.md``
derive from those.

The presets (:mod:`skelfilter.presets`) fill the fields left unset (``None``, or ``"preset"`` for a
choice).
"""

from skelfilter.params.denoise import MESH_FIELDS, DenoiseParams, voxel_fields_given
from skelfilter.params.synthetic_noise import NoiseParams
from skelfilter.params.volume_input import VolumeParams

__all__ = ["MESH_FIELDS", "DenoiseParams", "NoiseParams", "VolumeParams", "voxel_fields_given"]
