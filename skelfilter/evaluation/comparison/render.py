"""Headless pictures for the report: VTK (through pyvista) drawing into OSMesa, no display needed.

Every cell of a model's row uses the same camera, the same light kit and smooth shading (vertex
normals, split at edges sharper than ``FEATURE_ANGLE`` so a sharp edge looks sharp wherever a mesh
has one), so differences between cells are differences between meshes.
"""

import contextlib
import ctypes.util
import os
from dataclasses import dataclass

import numpy as np

from skelfilter.evaluation.metrics import sharp_edges
from skelfilter.runtime.extras import need
from skelfilter.runtime.signals import deferred

# The environment variable with which VTK makes its render windows with OSMesa.
_WINDOW_ENV = "VTK_DEFAULT_OPENGL_WINDOW"

FEATURE_ANGLE = 45.0  # degrees
MESH_COLOUR = (0.74, 0.78, 0.88)
VIEW_ANGLE = 30.0  # degrees, the camera's vertical field of view
CLOSEUP = 0.28  # close-up distance as a share of the overview's


@dataclass(frozen=True)
class Camera:
    position: tuple
    focal_point: tuple
    up: tuple

    def as_pyvista(self):
        return [self.position, self.focal_point, self.up]


def camera_for(mesh, view, up):
    """A camera looking at the whole of ``mesh`` from direction ``view`` (centre -> eye)."""
    view = np.asarray(view, dtype=float) / np.linalg.norm(view)
    lo, hi = mesh.bounds
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    distance = 1.05 * radius / np.sin(np.radians(VIEW_ANGLE / 2))
    return Camera(tuple(centre + distance * view), tuple(centre), tuple(map(float, up)))


def closeup_camera(clean, camera, angle=30.0):
    """A close-up of the clean mesh's sharp edge nearest to ``camera`` (its most dihedral edge when
    none exceeds ``angle``), seen from the same direction."""
    edges = sharp_edges(clean, angle)
    if len(edges) == 0:
        edges = clean.face_adjacency_edges[[np.argmax(clean.face_adjacency_angles)]]
    mid = clean.vertices[edges].mean(axis=1)
    eye, focus = np.asarray(camera.position), np.asarray(camera.focal_point)
    toward = (eye - focus) / np.linalg.norm(eye - focus)
    target = mid[np.argmax(mid @ toward)]
    distance = CLOSEUP * np.linalg.norm(eye - focus)
    return Camera(tuple(target + distance * toward), tuple(target), camera.up)


@contextlib.contextmanager
def _offscreen_window():
    """OSMesa renders on the CPU without an X server or a GPU (the system library libosmesa6); without
    it VTK tries X, then EGL (Mesa's llvmpipe also renders on the CPU). VTK is told so while a
    picture is drawn; the process's environment is as it was afterwards, and a choice of the user's
    (the variable set) stands."""
    if os.environ.get(_WINDOW_ENV) is not None or not ctypes.util.find_library("OSMesa"):
        yield
        return
    os.environ[_WINDOW_ENV] = "vtkOSOpenGLRenderWindow"
    try:
        yield
    finally:
        os.environ.pop(_WINDOW_ENV, None)


def _polydata(mesh):
    pv = need("pyvista", "the comparison's pictures")

    return pv.PolyData.from_regular_faces(np.asarray(mesh.vertices, dtype=float),
                                          np.asarray(mesh.faces, dtype=np.int64))


def render(mesh, camera, path, size, scalars=None, clim=None, cmap="viridis"):
    """Draw ``mesh`` into a PNG at ``path``; with ``scalars`` (one per vertex) as a colour map over
    ``clim`` without shading variation from the colour, else in a plain colour."""
    # Held signals: an interrupt inside VTK's lazy imports or its OpenGL context left VTK half set up,
    # and the process crashed on the way out; it acts once the picture is drawn.
    with deferred():
        pv = need("pyvista", "the comparison's pictures")
        with _offscreen_window():
            _draw(pv.Plotter(off_screen=True, window_size=list(size)), mesh, camera, path, scalars, clim, cmap)


def _draw(plotter, mesh, camera, path, scalars, clim, cmap):
    try:
        plotter.set_background("white")
        options = dict(smooth_shading=True, split_sharp_edges=True, feature_angle=FEATURE_ANGLE)
        if scalars is None:
            plotter.add_mesh(_polydata(mesh), color=MESH_COLOUR, **options)
        else:
            data = _polydata(mesh)
            data.point_data["distance"] = np.asarray(scalars, dtype=float)
            plotter.add_mesh(data, scalars="distance", clim=clim, cmap=cmap, show_scalar_bar=False, **options)
        plotter.camera_position = camera.as_pyvista()
        plotter.camera.view_angle = VIEW_ANGLE
        plotter.screenshot(path)
    finally:
        plotter.close()


def colour_bar(path, clim, label, cmap="viridis"):
    """A horizontal legend for the colour maps (matplotlib)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5.0, 0.75), dpi=110)
    ax = fig.subplots()
    fig.colorbar(ScalarMappable(Normalize(*clim), cmap), cax=ax, orientation="horizontal", label=label,
                 extend="max")
    fig.subplots_adjust(left=0.05, right=0.95, bottom=0.55, top=0.95)
    fig.savefig(path)
