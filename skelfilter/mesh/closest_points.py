"""Exact closest points on a triangle mesh: libigl's axis-aligned bounding-box tree, set up in one place."""

import numpy as np

from skelfilter.runtime.extras import load


class MeshSurface:
    """A triangle mesh prepared for exact point-to-triangle queries, in the mesh's units (float64).

    Examples
    --------
    >>> import trimesh
    >>> surface = MeshSurface(trimesh.creation.box())
    >>> [round(float(d), 3) for d in surface.distance([[0.0, 0.0, 1.5], [0.0, 0.0, 0.0]])]
    [1.0, 0.5]
    """

    def __init__(self, mesh):
        igl = load("igl")

        self._vertices = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
        self._faces = np.ascontiguousarray(mesh.faces, dtype=np.int64)
        self._tree = igl.AABB()
        self._tree.init(self._vertices, self._faces)

    def _query(self, points):
        points = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        if len(points) == 0:
            return np.zeros(0), np.zeros(0, dtype=np.int64), np.zeros((0, 3))
        squared, face, closest = self._tree.squared_distance(self._vertices, self._faces, points)
        return np.sqrt(np.maximum(squared, 0.0)), face, closest

    def distance(self, points):
        """Distances from ``points`` (n, 3) to the surface."""
        return self._query(points)[0]

    def closest_points(self, points):
        """The closest points of the surface, (n, 3)."""
        return self._query(points)[2]

    def closest(self, points):
        """Distances from ``points`` to the surface, and the index of each closest face."""
        distance, face, _ = self._query(points)
        return distance, face.astype(np.int64)


def within(mesh, points, radius):
    """Whether each of ``points`` (n, 3) lies within ``radius`` of ``mesh``'s surface (exact)."""
    return MeshSurface(mesh).distance(points) <= radius
