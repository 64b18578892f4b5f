"""Where the pictures are taken from: one camera for every picture of a model, whichever renderer draws it.

A configured comparison names its views; a mesh a user brings gets `view_for`: its up axis by the
file format's convention, and of the directions a little above the horizon the one that faces most
of its surface and of its features (a rabbit from the side its face and ears are on, not from above
and behind). The close-up looks at a sharp edge of the clean model
(`closeup_camera`) or at the spot where the results differ most (`closeup_where_differ`).
"""

from dataclasses import dataclass

import numpy as np

from skelfilter.evaluation.metrics import sharp_edges

VIEW_ANGLE = 30.0  # degrees, the camera's vertical field of view
CLOSEUP = 0.28  # close-up distance as a share of the overview's
ELEVATION = 20.0  # degrees above the horizon of the automatic view
AZIMUTHS = 24  # directions around the up axis tried by the automatic view
# File formats whose models stand on z (CAD, printing); the others stand on y (OBJ, PLY, OFF, glTF).
Z_UP_FORMATS = (".stl", ".3mf", ".step", ".stp")


@dataclass(frozen=True)
class Camera:
    position: tuple
    focal_point: tuple
    up: tuple

    @property
    def direction(self):
        """Unit vector from the focal point towards the eye."""
        toward = np.subtract(self.position, self.focal_point)
        return toward / np.linalg.norm(toward)

    def as_pyvista(self):
        return [self.position, self.focal_point, self.up]


def camera_for(mesh, view, up):
    """A camera looking at the whole of ``mesh`` from direction ``view`` (centre -> eye)."""
    view = np.asarray(view, dtype=float) / np.linalg.norm(view)
    lo, hi = mesh.bounds
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    distance = 1.05 * radius / np.sin(np.radians(VIEW_ANGLE / 2))
    return Camera(tuple(centre + distance * view), tuple(centre), tuple(map(float, up)))


def direction_from_angles(elevation, azimuth):
    """The direction (centre -> eye) at ``elevation`` degrees above the x-y plane and ``azimuth``
    degrees from x towards y: a fixed view of z-up models, as matplotlib names its views."""
    e, a = np.radians(elevation), np.radians(azimuth)
    return (float(np.cos(e) * np.cos(a)), float(np.cos(e) * np.sin(a)), float(np.sin(e)))


def up_for(path):
    """The up axis of a model stored at ``path``, by its format's convention."""
    z_up = str(path).lower().endswith(Z_UP_FORMATS)
    return (0.0, 0.0, 1.0) if z_up else (0.0, 1.0, 0.0)


def view_for(mesh, up=(0.0, 1.0, 0.0)):
    r"""The direction (centre -> eye) of the automatic view of ``mesh`` with ``up`` as its up axis.

    Of `AZIMUTHS` directions ``d`` `ELEVATION` degrees above the horizon, the one maximising

    .. math:: \frac{\sum_f A_f \max(0, n_f \cdot d)}{\sum_f A_f}
              + \frac{\sum_e l_e \theta_e \max(0, n_e \cdot d)}{\sum_e l_e \theta_e}

    over faces ``f`` (area, normal) and edges ``e`` (length, dihedral angle, the mean of its faces'
    normals): the share of the surface the camera faces, and the share of the shape's features
    (its integrated mean curvature) it faces. On a closed surface the first is the same from
    opposite sides; the second picks the side where the shape has its features. Both depend on the
    shape, not on how it is tessellated.
    """
    up = np.asarray(up, dtype=float) / np.linalg.norm(up)
    side = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    ahead = np.cross(up, side)
    azimuth = np.linspace(0.0, 2 * np.pi, AZIMUTHS, endpoint=False)[:, None]
    e = np.radians(ELEVATION)
    directions = np.cos(e) * (np.cos(azimuth) * side + np.sin(azimuth) * ahead) + np.sin(e) * up
    normals = np.asarray(mesh.face_normals)
    surface = np.clip(directions @ normals.T, 0.0, None) @ mesh.area_faces / max(float(mesh.area), 1e-300)
    edge_normals = normals[mesh.face_adjacency].sum(axis=1)
    edge_normals /= np.maximum(np.linalg.norm(edge_normals, axis=1), 1e-12)[:, None]
    lengths = np.linalg.norm(np.diff(mesh.vertices[mesh.face_adjacency_edges], axis=1)[:, 0], axis=1)
    feature = lengths * mesh.face_adjacency_angles
    features = np.clip(directions @ edge_normals.T, 0.0, None) @ feature / max(float(feature.sum()), 1e-300)
    return tuple(float(x) for x in directions[int(np.argmax(surface + features))])


def closeup_camera(clean, camera, angle=30.0):
    """A close-up of the clean mesh's sharp edge nearest to ``camera`` (its most dihedral edge when
    none exceeds ``angle``), seen from the same direction."""
    edges = sharp_edges(clean, angle)
    if len(edges) == 0:
        edges = clean.face_adjacency_edges[[np.argmax(clean.face_adjacency_angles)]]
    mid = clean.vertices[edges].mean(axis=1)
    return _closeup_at(mid[np.argmax(mid @ camera.direction)], camera)


def closeup_where_differ(points, normals, spread, camera, neighbours=50):
    """A close-up of the spot where the results differ most, seen from ``camera``'s direction.

    ``spread`` (one per point of ``points``, the surface points with their unit ``normals``) is how
    far apart the results lie there; it is averaged over each point's ``neighbours`` nearest points
    (a spot, not one stray vertex), and of the points facing the camera the one with the largest
    average is looked at.
    """
    from scipy.spatial import cKDTree

    points = np.asarray(points, dtype=float)
    k = min(neighbours, len(points))
    _, near = cKDTree(points).query(points, k=k)
    spot = np.asarray(spread, dtype=float)[near.reshape(len(points), k)].mean(axis=1)
    facing = np.asarray(normals) @ camera.direction > 0.2
    if facing.any():
        spot = np.where(facing, spot, -np.inf)
    return _closeup_at(points[int(np.argmax(spot))], camera)


def _closeup_at(target, camera):
    distance = CLOSEUP * np.linalg.norm(np.subtract(camera.position, camera.focal_point))
    return Camera(tuple(map(float, target + distance * camera.direction)), tuple(map(float, target)), camera.up)
