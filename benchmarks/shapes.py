"""The clean shapes of the quality benchmark (``benchmarks/quality.py``), as trimesh meshes.

Six come from files (fandisk, the rocker arm, the Stanford bunny, spot, the twelve-sided CAD solid of
``tests/data/twelve-impulsive`` and trimesh's cube); four CAD parts are built here with manifold3d's
booleans, z up. Every shape is centred on its bounding box and scaled to a longest side of 1, so at
the benchmark's 160 voxels one voxel is 1/160 = 0.00625. The built parts' holes, bosses, pockets and
ribs are 0.08 or more across (13+ voxels, above the noise's reach of up to ~9 voxels); the U-channel's
walls are 0.0625 (10 voxels) on purpose. All are watertight and manifold except the bunny, which has
holes in its base (the voxelizer closes them consistently).
"""

import functools
import os
from dataclasses import dataclass

import manifold3d
import numpy as np
import trimesh

from skelfilter import io
from skelfilter.demo import sample_path

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "tests", "data")
# Facets of the built cylinders: neighbours 3.75 degrees apart, far below the 30 degrees at which
# skelfilter.metrics.sharp_edges calls an edge sharp, so only the rims count as sharp edges.
SEGMENTS = 96
Z_UP = (0.0, 0.0, 1.0)
Y_UP = (0.0, 1.0, 0.0)


@dataclass(frozen=True)
class Shape:
    """A benchmark shape: how to build it and what is known about it."""

    name: str
    build: object  # () -> trimesh.Trimesh, in the shape's own units
    cad: bool  # a CAD part: its sharp edges must stay (the sharp-edge target applies)
    genus: int  # through holes, known from the shape's construction or source
    view: tuple = (1.0, 0.8, 1.2)  # camera direction for pictures, from the centre towards the eye
    up: tuple = Y_UP


def _from_file(path):
    """A loader of a mesh file with coincident vertices merged (OBJ files split them at UV seams)."""
    def load():
        mesh = io.load_mesh(path)
        mesh.merge_vertices(merge_tex=True, merge_norm=True)
        return mesh
    return load


def _cube():
    return trimesh.creation.box(extents=(1.0, 1.0, 1.0))


def _cylinder(radius, height, x=0.0, y=0.0, z=0.0):
    """A z-axis cylinder whose base circle is centred at (x, y, z)."""
    return manifold3d.Manifold.cylinder(height, radius, -1.0, SEGMENTS).translate((x, y, z))


def _box(size, centre):
    return manifold3d.Manifold.cube(size, True).translate(centre)


def _to_trimesh(solid):
    """The triangle mesh of a manifold3d solid, its coincident vertices merged."""
    mesh = solid.to_mesh()
    return trimesh.Trimesh(np.asarray(mesh.vert_properties)[:, :3], np.asarray(mesh.tri_verts), process=True)


def block_with_holes_and_boss():
    """A 1 x 0.6 x 0.35 block with two vertical through holes (diameter 0.16) and a cylindrical boss
    (diameter 0.24, 0.15 high) on top between them: genus 2."""
    block = _box((1.0, 0.6, 0.35), (0.0, 0.0, 0.0))
    holes = [_cylinder(0.08, 1.0, x, 0.0, -0.5) for x in (-0.3, 0.3)]
    boss = _cylinder(0.12, 0.2, 0.0, 0.0, 0.125)  # 0.05 inside the block: the union is clean
    return _to_trimesh(manifold3d.Manifold.batch_boolean([block, boss], manifold3d.OpType.Add)
                       - manifold3d.Manifold.batch_boolean(holes, manifold3d.OpType.Add))


def plate_with_pockets():
    """A 1 x 0.7 x 0.2 plate with a 0.3 x 0.25 rectangular and a diameter-0.2 round blind pocket,
    0.1 deep, and a 45-degree chamfer (legs 0.15) along one top edge: genus 0."""
    plate = _box((1.0, 0.7, 0.2), (0.0, 0.0, 0.0))
    pockets = [_box((0.3, 0.25, 0.2), (-0.25, 0.0, 0.1)), _cylinder(0.1, 0.2, 0.15, 0.0, 0.0)]
    solid = plate - manifold3d.Manifold.batch_boolean(pockets, manifold3d.OpType.Add)
    # Keep x + z <= 0.45: the top edge at x = 0.5, z = 0.1 becomes a slanted face.
    return _to_trimesh(solid.trim_by_plane((-1.0, 0.0, -1.0), -0.45 / np.sqrt(2.0)))


def u_channel():
    """A U-channel 1 long, 0.5 wide and 0.4 high whose floor and walls are 0.0625 thick: genus 0."""
    wall = 0.0625
    outer = _box((1.0, 0.5, 0.4), (0.0, 0.0, 0.0))
    return _to_trimesh(outer - _box((1.2, 0.5 - 2 * wall, 0.4), (0.0, 0.0, wall)))


def l_bracket():
    """An L-bracket: a 1 x 0.6 x 0.12 base and a 0.7 high upright, both 0.12 thick, a through slot
    (0.12 wide, 0.35 long, rounded ends) in the base and a triangular rib 0.1 thick in the inner
    corner: genus 1."""
    base = _box((1.0, 0.6, 0.12), (0.5, 0.3, 0.06))
    upright = _box((0.12, 0.6, 0.7), (0.06, 0.3, 0.35))
    rib = manifold3d.Manifold.hull_points(
        [(x, y, z) for y in (0.25, 0.35) for x, z in ((0.1, 0.1), (0.42, 0.1), (0.1, 0.42))])
    slot = manifold3d.Manifold.batch_hull([_cylinder(0.06, 1.0, x, 0.3, -0.5) for x in (0.62, 0.85)])
    solid = manifold3d.Manifold.batch_boolean([base, upright, rib], manifold3d.OpType.Add) - slot
    return _to_trimesh(solid)


SHAPES = {s.name: s for s in (
    Shape("fandisk", _from_file(sample_path()), cad=True, genus=0, view=(1.0, 0.6, -1.2)),
    Shape("rocker-arm", _from_file(os.path.join(DATA, "rocker-arm.obj")), cad=True, genus=1,
          view=(0.6, 0.5, 1.0)),
    Shape("bunny", _from_file(os.path.join(DATA, "stanford-bunny.obj")), cad=False, genus=0,
          view=(0.3, 0.3, 1.0)),
    Shape("spot", _from_file(os.path.join(DATA, "spot.obj")), cad=False, genus=0, view=(1.0, 0.5, 1.2)),
    Shape("twelve", _from_file(os.path.join(DATA, "twelve-impulsive", "clean.obj")), cad=True, genus=0),
    Shape("cube", _cube, cad=True, genus=0, view=(1.0, 0.7, 1.3)),
    Shape("block", block_with_holes_and_boss, cad=True, genus=2, view=(0.9, -1.2, 1.1), up=Z_UP),
    Shape("pocket-plate", plate_with_pockets, cad=True, genus=0, view=(0.7, -1.0, 1.5), up=Z_UP),
    Shape("u-channel", u_channel, cad=True, genus=0, view=(1.0, -1.3, 1.2), up=Z_UP),
    Shape("l-bracket", l_bracket, cad=True, genus=1, view=(1.3, -1.0, 0.9), up=Z_UP),
)}


@functools.lru_cache(maxsize=None)
def load(name):
    """The clean mesh of shape ``name``, centred on its bounding box, longest side 1.

    The mesh is cached and shared between callers: do not modify it.

    Raises
    ------
    KeyError
        For a name not in ``SHAPES``.
    """
    mesh = SHAPES[name].build()
    lo, hi = mesh.bounds
    mesh.apply_translation(-(lo + hi) / 2)
    mesh.apply_scale(1.0 / (hi - lo).max())
    return mesh
