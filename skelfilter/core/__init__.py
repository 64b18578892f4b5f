"""The thesis' stages on arrays: distance and feature fields, the skeleton, its importance and
saliency, the EDT filters, the reconstruction, the noise model and the volume pipeline.

Imports only :mod:`skelfilter.runtime`, :mod:`skelfilter.params` and :mod:`skelfilter.errors`
(never trimesh or open3d), so a volume runs through it with numpy, scipy and numba alone.
"""
