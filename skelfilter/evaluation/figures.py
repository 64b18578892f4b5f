"""Headless pictures of meshes (matplotlib figures drawn off-screen): same camera and light for every
panel. No pyplot: no backend is chosen for the process and no figure is left open."""

import numpy as np
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection


def _shade(normals, light):
    return 0.25 + 0.75 * np.clip(normals @ light, 0.0, 1.0)


def draw_mesh(ax, mesh, elev=25.0, azim=-60.0, color=(0.72, 0.76, 0.86), bounds=None):
    """Draw ``mesh`` flat-shaded from a fixed light on a 3-D matplotlib axis."""
    ax.view_init(elev=elev, azim=azim)
    e, a = np.radians(elev), np.radians(azim)
    eye = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    light = eye + np.array([0.0, 0.0, 0.6])
    light /= np.linalg.norm(light)
    shade = _shade(mesh.face_normals, light)[:, None]
    colors = np.hstack([np.clip(shade * np.asarray(color), 0, 1), np.ones((len(shade), 1))])
    ax.add_collection3d(Poly3DCollection(mesh.triangles, facecolors=colors, edgecolors="none", linewidths=0))
    lo, hi = bounds if bounds is not None else mesh.bounds
    centre, half = (lo + hi) / 2, (hi - lo).max() / 2
    for set_lim, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), centre):
        set_lim(c - half, c + half)
    ax.set_box_aspect((1, 1, 1))
    ax.set_axis_off()


def save_panels(meshes, titles, path, elev=25.0, azim=-60.0, size=4.0):
    """One row of panels, one per mesh, sharing the first mesh's framing; writes a PNG."""
    fig = Figure(figsize=(size * len(meshes), size), dpi=110)
    bounds = meshes[0].bounds
    for i, (mesh, title) in enumerate(zip(meshes, titles)):
        ax = fig.add_subplot(1, len(meshes), i + 1, projection="3d")
        draw_mesh(ax, mesh, elev, azim, bounds=bounds)
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(path)
