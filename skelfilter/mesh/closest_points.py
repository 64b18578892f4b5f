"""Exact closest points on a triangle mesh: open3d's ray-casting scene, set up in one place."""

import numpy as np


class MeshSurface:
    """A triangle mesh prepared for exact point-to-triangle queries, in the mesh's units.

    Examples
    --------
    >>> import trimesh
    >>> surface = MeshSurface(trimesh.creation.box())
    >>> [round(float(d), 3) for d in surface.distance([[0.0, 0.0, 1.5], [0.0, 0.0, 0.0]])]
    [1.0, 0.5]
    """

    def __init__(self, mesh):
        import open3d as o3d  # imported where used: it needs the system's libusb

        self._o3d = o3d
        self._scene = o3d.t.geometry.RaycastingScene()
        self._scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, dtype=np.float32)),
                                  o3d.core.Tensor(np.asarray(mesh.faces, dtype=np.uint32)))

    def _tensor(self, points):
        return self._o3d.core.Tensor(np.asarray(points, dtype=np.float32))

    def distance(self, points):
        """Distances (float32) from ``points`` (n, 3) to the surface."""
        return self._scene.compute_distance(self._tensor(points)).numpy()

    def closest_points(self, points):
        """The closest points of the surface (float32, (n, 3))."""
        return self._scene.compute_closest_points(self._tensor(points))["points"].numpy()

    def closest(self, points):
        """Distances (float64) from ``points`` to the surface, and the index of each closest face."""
        points = np.asarray(points, dtype=np.float32)
        found = self._scene.compute_closest_points(self._tensor(points))
        distance = np.linalg.norm(found["points"].numpy() - points, axis=1).astype(np.float64)
        return distance, found["primitive_ids"].numpy().astype(np.int64)
