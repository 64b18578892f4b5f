"""Measures that need no clean reference, for a user's own noisy mesh.

How rough the result is (the roughness by which skelfilter routes a mesh), how far its surface lies
from the input's (`surface_distances`), how much its face normals turned (`normal_error` against the
input) and its volume changed; `skelfilter.evaluation.metrics.change_measures` gives them all. None of these says the
result is right; together they tell a filter that smoothed from one that left the noise in, and one
that also moved or shrank the shape.
"""

from skelfilter.mesh import surface_roughness


def roughness(mesh):
    """`skelfilter.mesh.surface_roughness.roughness` of ``mesh`` (degrees)."""
    points, normals = surface_roughness.surface_samples(mesh.vertices, mesh.faces)
    return float(surface_roughness.roughness(points, normals))


def volume_change(result, source):
    """Relative change of the enclosed volume, ``(V_result - V_source) / V_source``; NaN unless both
    are closed (watertight) with a volume."""
    if not (result.is_watertight and source.is_watertight) or source.volume == 0:
        return float("nan")
    return float((abs(result.volume) - abs(source.volume)) / abs(source.volume))
