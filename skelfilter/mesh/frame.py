"""The unit frame a mesh is processed in, so that results do not depend on its scale or position.

A mesh is moved to the centre of its bounding box and divided by a power of two near its longest
side before anything else, and the results are taken back afterwards. Every absolute tolerance of
the libraries used (trimesh merges vertices closer than 1e-8, for one) then
acts relative to the mesh's size, and a mesh scaled by a power of two gives bit-identical results.
"""

from dataclasses import dataclass

import numpy as np
import trimesh

from skelfilter.mesh.voxelize import Grid


@dataclass(frozen=True)
class Frame:
    """World = unit * ``scale`` + ``centre``.

    Attributes
    ----------
    centre : ndarray, shape (3,)
        World position of the unit frame's origin: the centre of the mesh's bounding box.
    scale : float
        World length of a unit: the power of two nearest the bounding box's longest side.
    """

    centre: np.ndarray
    scale: float

    @classmethod
    def of(cls, mesh):
        """The frame of ``mesh``'s bounding box (its vertices must be finite and not all equal)."""
        bounds = np.asarray(mesh.bounds, dtype=np.float64)
        longest = float(np.max(bounds[1] - bounds[0]))
        return cls(centre=(bounds[0] + bounds[1]) / 2, scale=float(2.0 ** np.round(np.log2(longest))))

    def to_unit(self, mesh):
        """``mesh``'s geometry (vertices and faces only) in the unit frame."""
        vertices = (np.asarray(mesh.vertices, dtype=np.float64) - self.centre) / self.scale
        return trimesh.Trimesh(vertices, np.asarray(mesh.faces), process=False)

    def to_world(self, mesh):
        """A mesh made in the unit frame, in world coordinates (in place; returns it)."""
        mesh.vertices = np.asarray(mesh.vertices, dtype=np.float64) * self.scale + self.centre
        return mesh

    def moved(self, mesh, unit_mesh, unit_vertices):
        """``mesh`` (world) with the vertices that moved from ``unit_mesh``'s to ``unit_vertices``
        moved alike: the displacement is scaled back, so unmoved vertices keep their exact
        coordinates, and colours, UVs and the like come along."""
        out = mesh.copy()
        displacement = (np.asarray(unit_vertices) - np.asarray(unit_mesh.vertices)) * self.scale
        out.vertices = np.asarray(mesh.vertices, dtype=np.float64) + displacement
        return out

    def grid_to_world(self, grid):
        """A grid laid in the unit frame, in world coordinates."""
        return Grid(grid.origin * self.scale + self.centre, grid.pitch * self.scale, grid.shape)
