"""Headless pictures of meshes (matplotlib figures drawn off-screen): same camera and light for every
panel. No pyplot: no backend is chosen for the process and no figure is left open.

The camera is the comparison's (`skelfilter.evaluation.camera`): a direction from the model's centre
towards the eye and an up axis; by default the view `camera.view_for` chooses for the first mesh.
"""

import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from skelfilter.evaluation import camera

MESH_COLOUR = (0.74, 0.78, 0.88)
# Lambert shading from a light at the eye, raised towards the up axis: AMBIENT lights the faces
# turned away, so the shape reads in every part.
AMBIENT = 0.38
LIGHT_RAISE = 0.5


def _upright(up):
    """A rotation (rows) taking ``up`` to +z, right-handed: matplotlib's 3-D axes stand on z."""
    up = np.asarray(up, dtype=float) / np.linalg.norm(up)
    first = np.cross(up, [1.0, 0.0, 0.0] if abs(up[0]) < 0.9 else [0.0, 1.0, 0.0])
    first /= np.linalg.norm(first)
    return np.array([first, np.cross(up, first), up])


def draw_mesh(ax, mesh, view=None, up=(0.0, 0.0, 1.0), color=MESH_COLOUR, bounds=None):
    """Draw ``mesh`` flat-shaded on a 3-D matplotlib axis, seen from ``view`` (centre -> eye; default
    `camera.view_for`) with ``up`` upwards, framed on ``bounds`` (default: the mesh's)."""
    view = camera.view_for(mesh, up) if view is None else view
    rotation = _upright(up)
    eye = rotation @ (np.asarray(view, dtype=float) / np.linalg.norm(view))
    ax.view_init(elev=np.degrees(np.arcsin(np.clip(eye[2], -1, 1))), azim=np.degrees(np.arctan2(eye[1], eye[0])))
    light = eye + np.array([0.0, 0.0, LIGHT_RAISE])
    light /= np.linalg.norm(light)
    shade = AMBIENT + (1 - AMBIENT) * np.clip((mesh.face_normals @ rotation.T) @ light, 0.0, 1.0)
    colors = np.hstack([np.clip(shade[:, None] * np.asarray(color), 0, 1), np.ones((len(shade), 1))])
    triangles = mesh.triangles @ rotation.T
    # edges drawn in the faces' colour close the hairline gaps antialiasing leaves between them
    ax.add_collection3d(Poly3DCollection(triangles, facecolors=colors, edgecolors=colors, linewidths=0.2))
    corners = np.array(np.meshgrid(*np.asarray(bounds if bounds is not None else mesh.bounds).T)).reshape(3, -1).T
    turned = corners @ rotation.T
    lo, hi = turned.min(axis=0), turned.max(axis=0)
    centre, half = (lo + hi) / 2, (hi - lo).max() / 2
    for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        set_lim(c - half, c + half)
    ax.set_box_aspect((1, 1, 1), zoom=1.25)
    ax.set_axis_off()


def save_panels(meshes, titles, path, view=None, up=(0.0, 0.0, 1.0), size=5.0):
    """One row of panels, one per mesh, sharing the first mesh's framing and one camera (``view``:
    centre -> eye, default `camera.view_for` of the first mesh; ``up``); writes a PNG."""
    view = camera.view_for(meshes[0], up) if view is None else view
    fig = Figure(figsize=(size * len(meshes), size), dpi=120)
    bounds = meshes[0].bounds
    for i, (mesh, title) in enumerate(zip(meshes, titles)):
        ax = fig.add_subplot(1, len(meshes), i + 1, projection="3d")
        draw_mesh(ax, mesh, view, up, bounds=bounds)
        ax.set_title(title)
    fig.subplots_adjust(left=0.0, right=1.0, bottom=0.0, top=0.93, wspace=0.0)
    fig.savefig(path)
