"""Exact closest points on a triangle mesh: open3d's ray-casting scene, set up in one place."""

import numpy as np

from skelfilter.runtime.extras import load


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
        o3d = load("open3d")  # loaded where used: it needs the system's libusb

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


# Point-face pairs measured one by one at most; past it open3d's scene answers.
_MOST_PAIRS = 2_000_000


def within(mesh, points, radius):
    """Whether each of ``points`` (n, 3) lies within ``radius`` of ``mesh``'s surface (exact).

    A point within ``radius`` of a vertex or a face centroid (points of the surface) is; the others
    are measured against the faces that can reach them: those whose centroid lies within ``radius``
    plus the face's own reach (its farthest vertex from the centroid). This takes tenths of a second
    where building open3d's scene (`MeshSurface`) first takes a second; where too many pairs are
    left, the scene answers.
    """
    from scipy.spatial import cKDTree
    from trimesh.triangles import closest_point

    points = np.asarray(points, dtype=np.float64)
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    triangles = vertices[faces]
    centroids = triangles.mean(axis=1)
    corners = vertices[np.unique(faces)]  # a vertex no face uses is not on the surface
    found = cKDTree(np.vstack([centroids, corners])).query(points, distance_upper_bound=radius)[0] <= radius
    open_ = np.flatnonzero(~found)
    if len(open_) == 0:
        return found
    reach = radius + np.linalg.norm(triangles - centroids[:, None], axis=2).max(axis=1)
    tree = cKDTree(points[open_])
    if tree.query_ball_point(centroids, reach, return_length=True).sum() > _MOST_PAIRS:
        found[open_] = MeshSurface(mesh).distance(points[open_]) <= radius
        return found
    near = tree.query_ball_point(centroids, reach)
    face = np.repeat(np.arange(len(near)), [len(n) for n in near])
    point = open_[np.concatenate([np.asarray(n, dtype=np.int64) for n in near])]
    gap = np.linalg.norm(closest_point(triangles[face], points[point]) - points[point], axis=1)
    found[point[gap <= radius]] = True
    return found
