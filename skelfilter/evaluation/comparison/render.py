"""Headless pictures for the report: VTK (through pyvista) drawing into OSMesa, no display needed.

Every cell of a model's row uses the same camera, the same light kit and smooth shading (vertex
normals, split at edges sharper than ``FEATURE_ANGLE`` so a sharp edge looks sharp wherever a mesh
has one), so differences between cells are differences between meshes.
"""

import contextlib
import ctypes.util
import os

import numpy as np

from skelfilter.evaluation.camera import VIEW_ANGLE
from skelfilter.runtime.extras import need
from skelfilter.runtime.signals import deferred

# The environment variable with which VTK makes its render windows with OSMesa.
_WINDOW_ENV = "VTK_DEFAULT_OPENGL_WINDOW"

FEATURE_ANGLE = 45.0  # degrees
MESH_COLOUR = (0.74, 0.78, 0.88)


def _window_class():
    """The render window VTK should make here, or None to let VTK choose.

    With a display VTK's own choice (X) works. Without one VTK tries X first and prints "bad X server
    connection" (in terminal colour codes) before it falls back; so OSMesa (the system library
    libosmesa6, rendering on the CPU) is named where it is installed, else EGL (Mesa's llvmpipe
    renders on the CPU too, a GPU's driver on it)."""
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return None
    for library, window in (("OSMesa", "vtkOSOpenGLRenderWindow"), ("EGL", "vtkEGLRenderWindow")):
        if ctypes.util.find_library(library):
            return window
    return None


@contextlib.contextmanager
def _offscreen_window():
    """VTK is told which render window to make (`_window_class`) while a picture is drawn; the
    process's environment is as it was afterwards, and a choice of the user's (the variable set)
    stands."""
    window = _window_class()
    if os.environ.get(_WINDOW_ENV) is not None or window is None:
        yield
        return
    os.environ[_WINDOW_ENV] = window
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
