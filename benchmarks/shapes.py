"""The clean shapes of the quality benchmark (``benchmarks/quality.py``), as trimesh meshes.

Six come from files (fandisk, the rocker arm, the Stanford bunny, spot, the twelve-sided CAD solid of
``skelfilter/data/twelve-impulsive`` and trimesh's cube); four CAD parts are built here with manifold3d's
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

from skelfilter.io import mesh_files
from skelfilter.io.samples import sample_path

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, "skelfilter", "data")
# Facets of the built cylinders: neighbours 3.75 degrees apart, far below the 30 degrees at which
# skelfilter.evaluation.metrics.sharp_edges calls an edge sharp, so only the rims count as sharp edges.
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
    thin: bool = False  # built with parts 2-8 voxels thick at 160 voxels (the thin-part measure's shapes)


def _from_file(path):
    """A loader of a mesh file with coincident vertices merged (OBJ files split them at UV seams)."""
    def load():
        mesh = mesh_files.load_mesh(path)
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



# The CAD shapes on which the mesh fine pass's guided rounds were chosen (benchmarks/literature.py
# --part cad, remeshed there): piecewise-flat prisms and solids, and curved faces meeting at creases.
def _star(points, inner, height, rounding=0.0):
    """A star prism: ``points`` tips at radius 1, notches at ``inner``, corners rounded by ``rounding``."""
    k = np.arange(2 * points)
    radius = np.where(k % 2 == 0, 1.0, inner)
    section = manifold3d.CrossSection([np.c_[radius * np.cos(k * np.pi / points), radius * np.sin(k * np.pi / points)]])
    if rounding:
        section = section.offset(rounding, manifold3d.JoinType.Round, circular_segments=64).offset(
            -rounding, manifold3d.JoinType.Round)
    return section.extrude(height)


def star_prism():
    """A six-pointed star prism, notches at 0.45 of the tips' radius, 0.5 high."""
    return _to_trimesh(_star(6, 0.45, 0.5))


def hex_nut():
    """A hexagonal prism (circumradius 1, 0.6 high) with a diameter-0.8 bore."""
    hexagon = manifold3d.CrossSection([np.c_[np.cos(np.arange(6) * np.pi / 3), np.sin(np.arange(6) * np.pi / 3)]])
    return _to_trimesh((hexagon - manifold3d.CrossSection.circle(0.4, SEGMENTS)).extrude(0.6))


def holed_l_prism():
    """An L-shaped section (4 x 3, legs 1 wide) with a diameter-0.6 hole, extruded 1.5."""
    section = manifold3d.CrossSection([np.array([(0, 0), (4, 0), (4, 1), (1, 1), (1, 3), (0, 3)], float)])
    return _to_trimesh((section - manifold3d.CrossSection.circle(0.3, SEGMENTS).translate((2.8, 0.5))).extrude(1.5))


def bored_block():
    """A 3 x 2 x 1.2 block with a diameter-1 bore through it and a cube standing on an edge on top."""
    block = _box((3.0, 2.0, 1.2), (0.0, 0.0, 0.0))
    bore = manifold3d.Manifold.cylinder(3.0, 0.5, -1.0, SEGMENTS, True).rotate((90.0, 0.0, 0.0)).translate((0.6, 0, 0))
    return _to_trimesh(block - bore + manifold3d.Manifold.cube((1.0, 1.0, 1.0), True).rotate(
        (0.0, 0.0, 45.0)).translate((-0.8, 0.0, 0.9)))


def sphere_box():
    """A unit sphere cut by a cube of side 1.5: six flat discs on a sphere, meeting it at creases."""
    return _to_trimesh(manifold3d.Manifold.sphere(1.0, 2 * SEGMENTS) ^ _box((1.5, 1.5, 1.5), (0.0, 0.0, 0.0)))


def domed_star():
    """A five-pointed star prism with rounded corners, its top cut by a sphere of radius 1.3."""
    dome = manifold3d.Manifold.sphere(1.3, 2 * SEGMENTS).translate((0.0, 0.0, -0.6))
    return _to_trimesh(_star(5, 0.55, 0.9, 0.08) ^ dome)


def grooved_cylinder():
    """A cylinder (radius 0.7, 1.2 high) with a groove of radius 0.25 around its top rim."""
    torus = manifold3d.CrossSection.circle(0.25, 48).translate((0.7, 0.0)).revolve(SEGMENTS)
    return _to_trimesh(manifold3d.Manifold.cylinder(1.2, 0.7, -1.0, SEGMENTS, True) - torus.translate((0, 0, 0.6)))


FINE_PASS_CAD = {"star-prism": star_prism, "hex-nut": hex_nut, "holed-l-prism": holed_l_prism,
                 "bored-block": bored_block, "sphere-box": sphere_box, "domed-star": domed_star,
                 "grooved-cylinder": grooved_cylinder}


# Thin-featured shapes: parts 2-8 voxels thick at the benchmark's 160 voxels (one voxel = 1/160 of the
# longest side), the features a denoiser must keep. VOXEL is that length.
VOXEL = 1.0 / 160.0


def _sphere(radius, centre=(0.0, 0.0, 0.0), scale=(1.0, 1.0, 1.0)):
    return manifold3d.Manifold.sphere(radius, SEGMENTS).scale(scale).translate(centre)


def _rod(start, end, radius, tip_radius=None):
    """A cylinder (a cone with ``tip_radius``) from point ``start`` to point ``end``."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    axis = end - start
    length = float(np.linalg.norm(axis))
    rod = manifold3d.Manifold.cylinder(length, radius, radius if tip_radius is None else tip_radius, SEGMENTS)
    z = axis / length
    x = np.cross(z, (0.0, 0.0, 1.0) if abs(z[2]) < 0.9 else (1.0, 0.0, 0.0))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return rod.transform(np.column_stack([x, y, z, start]))


def _slab(corners, thickness, axis=2):
    """The prism of thickness ``thickness`` along ``axis`` over the polygon ``corners`` (2-D points in
    the other two axes, in axis order), centred on 0 along ``axis``."""
    points = []
    for u, v in corners:
        for w in (-thickness / 2, thickness / 2):
            p = [u, v]
            p.insert(axis, w)
            points.append(tuple(p))
    return manifold3d.Manifold.hull_points(points)


def _union(parts):
    return manifold3d.Manifold.batch_boolean(list(parts), manifold3d.OpType.Add)


def airplane():
    """A 1-long airplane: a tapered fuselage (16 voxels across), wings 4 voxels thick spanning 0.9,
    a tail plane 3 voxels thick and a fin 2.5 voxels thick: genus 0."""
    fuselage = manifold3d.Manifold.batch_hull([_sphere(0.055, (-0.44, 0, 0)), _sphere(0.035, (0.46, 0, 0.02))])
    wings = _union([_slab([(-0.13, 0.0), (0.1, 0.0), (0.08, s * 0.45), (-0.02, s * 0.45)], 4 * VOXEL)
                    for s in (1, -1)])
    tail = _union([_slab([(0.34, 0.0), (0.46, 0.0), (0.47, s * 0.17), (0.42, s * 0.17)], 3 * VOXEL)
                   for s in (1, -1)]).translate((0, 0, 0.02))
    fin = _slab([(0.33, 0.0), (0.47, 0.0), (0.48, 0.18), (0.43, 0.18)], 2.5 * VOXEL, axis=1).translate((0, 0, 0.02))
    return _to_trimesh(_union([fuselage, wings, tail, fin]))


def fin_plate():
    """A 1 x 0.4 x 0.06 plate with six upright fins 0.22 high, 2, 3, 4, 5, 6 and 8 voxels thick: genus 0
    (a heat sink)."""
    plate = _box((1.0, 0.4, 0.06), (0.0, 0.0, 0.0))
    fins = [_box((t * VOXEL, 0.36, 0.22), (x, 0.0, 0.13)) for t, x in zip((2, 3, 4, 5, 6, 8),
                                                                           np.linspace(-0.4, 0.4, 6))]
    return _to_trimesh(_union([plate] + fins))


def chair():
    """A chair 1 high: a seat 5 voxels thick, four legs 6 voxels square, a back of two posts and three
    slats 4 voxels thick: genus 3 (the openings of the back)."""
    seat = _box((0.5, 0.5, 5 * VOXEL), (0.0, 0.0, 0.45))
    leg = 6 * VOXEL
    legs = [_box((leg, leg, 0.45), (x, y, 0.225)) for x in (-0.22, 0.22) for y in (-0.22, 0.22)]
    posts = [_box((leg, leg, 0.55), (x, 0.22, 0.72)) for x in (-0.22, 0.22)]
    slats = [_box((0.44, 4 * VOXEL, 0.05), (0.0, 0.22, z)) for z in (0.62, 0.78, 0.94)]
    return _to_trimesh(_union([seat] + legs + posts + slats))


def quadruped():
    """A 1-long four-legged animal: an ellipsoid body, legs 7 voxels thick, a head with two horns
    (cones from 4 voxels across to a point), two ears 2.5 voxels thick and a tail 3 voxels thick:
    genus 0."""
    body = _sphere(1.0, (0.0, 0.0, 0.0), (0.3, 0.13, 0.13))
    legs = [_rod((x, y, -0.06), (x, y, -0.42), 3.5 * VOXEL) for x in (-0.2, 0.2) for y in (-0.07, 0.07)]
    head = manifold3d.Manifold.batch_hull([_sphere(0.08, (0.22, 0.0, 0.06)), _sphere(0.085, (0.38, 0.0, 0.12))])
    horns = [_rod((0.38, s * 0.05, 0.18), (0.36, s * 0.13, 0.3), 2 * VOXEL, 0.3 * VOXEL) for s in (1, -1)]
    ears = [_sphere(1.0, (0.33, s * 0.11, 0.17), (0.035, 0.06, 2.5 * VOXEL / 2)) for s in (1, -1)]
    tail = _rod((-0.28, 0.0, 0.02), (-0.5, 0.0, -0.18), 1.5 * VOXEL)
    return _to_trimesh(_union([body, head] + legs + horns + ears + [tail]))


def mug():
    """A mug 0.7 high and 0.6 across with a wall and a handle 5 voxels thick (after scaling to a longest
    side of 1): genus 1."""
    wall = 0.025
    outer = manifold3d.Manifold.cylinder(0.7, 0.3, -1.0, SEGMENTS)
    inner = manifold3d.Manifold.cylinder(0.7, 0.3 - wall, -1.0, SEGMENTS).translate((0, 0, 0.05))
    ring = manifold3d.Manifold.revolve(manifold3d.CrossSection.circle(0.012, 24).translate((0.15, 0.0)),
                                       SEGMENTS).scale((1.0, 1.0, 1.4))
    handle = ring.rotate((90.0, 0.0, 0.0)).translate((0.3, 0.0, 0.36)) - _cylinder(0.29, 1.0, 0, 0, -0.2)
    return _to_trimesh(_union([outer - inner, handle]))



def stool():
    """A round stool 1 high: a seat disc 0.5 across and 6 voxels thick on three legs 5 voxels across,
    splayed outwards and joined by a ring rung 4 voxels thick: genus 3 (the ring's own loop, and two
    more through the three legs between the ring and the seat)."""
    seat = manifold3d.Manifold.cylinder(6 * VOXEL, 0.25, -1.0, SEGMENTS).translate((0, 0, 1.0 - 6 * VOXEL))
    angles = np.radians([90.0, 210.0, 330.0])
    legs = [_rod((0.17 * np.cos(a), 0.17 * np.sin(a), 1.0 - 6 * VOXEL), (0.24 * np.cos(a), 0.24 * np.sin(a), 0.0),
                 2.5 * VOXEL) for a in angles]
    ring = manifold3d.Manifold.revolve(manifold3d.CrossSection.circle(2 * VOXEL, 16).translate((0.205, 0.0)),
                                       SEGMENTS).translate((0, 0, 0.35))
    return _to_trimesh(_union([seat, ring] + legs))


def gear():
    """A spur gear 1 across and 0.16 thick with 24 teeth 0.06 high (10 voxels) and 4 voxels wide at the
    tip, a hub bore 0.2 across and six round lightening holes: genus 7."""
    body = manifold3d.Manifold.cylinder(0.16, 0.44, -1.0, SEGMENTS * 2)
    teeth = []
    for a in np.linspace(0.0, 360.0, 24, endpoint=False):
        outline = [(0.43, -0.035), (0.5, -2 * VOXEL), (0.5, 2 * VOXEL), (0.43, 0.035)]
        tooth = _slab(outline, 0.16).translate((0, 0, 0.08))
        teeth.append(tooth.rotate((0.0, 0.0, float(a))))
    holes = [_cylinder(0.1, 1.0, 0, 0, -0.5)] + [
        _cylinder(0.06, 1.0, 0.28 * np.cos(a), 0.28 * np.sin(a), -0.5) for a in np.radians(np.arange(0, 360, 60))]
    return _to_trimesh(_union([body] + teeth) - _union(holes))


def procedural(seed):
    """A made-up shape with thin parts, for training a decision over many shapes: a body (a box, an
    ellipsoid or a cylinder) with 2-6 rods (radius 2-7 voxels at 160 of the body's longest side) and
    plates (2-8 voxels thick) through it at random directions. The same seed gives the same shape."""
    rng = np.random.default_rng(seed)
    extent = rng.uniform(0.25, 0.5, 3)
    body = [manifold3d.Manifold.cube(extent, True),
            manifold3d.Manifold.sphere(0.5, SEGMENTS).scale(tuple(extent)),
            manifold3d.Manifold.cylinder(extent[2], extent[0] / 2, -1.0, SEGMENTS, True)][int(rng.integers(3))]
    parts = [body]
    for _ in range(int(rng.integers(2, 7))):
        turn = tuple(float(a) for a in rng.uniform(0, 360, 3))
        offset = tuple(float(v) for v in rng.uniform(-0.15, 0.15, 3))
        if rng.random() < 0.5:
            radius, length = rng.uniform(2, 7) / 160, rng.uniform(0.5, 1.0)
            part = manifold3d.Manifold.cylinder(length, radius, -1.0, 32, True)
        else:
            thickness, side = rng.uniform(2, 8) / 160, rng.uniform(0.3, 0.6, 2)
            part = manifold3d.Manifold.cube((side[0], side[1], thickness), True)
        parts.append(part.rotate(turn).translate(offset))
    return _to_trimesh(_union(parts))


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
    Shape("airplane", airplane, cad=False, genus=0, view=(0.8, -1.0, 0.9), up=Z_UP, thin=True),
    Shape("fin-plate", fin_plate, cad=True, genus=0, view=(0.6, -1.2, 0.9), up=Z_UP, thin=True),
    Shape("chair", chair, cad=True, genus=3, view=(1.0, -1.3, 0.8), up=Z_UP, thin=True),
    Shape("quadruped", quadruped, cad=False, genus=0, view=(0.3, -1.2, 0.4), up=Z_UP, thin=True),
    Shape("mug", mug, cad=True, genus=1, view=(1.0, -1.2, 0.9), up=Z_UP, thin=True),
    Shape("stool", stool, cad=True, genus=3, view=(1.0, -1.3, 0.7), up=Z_UP, thin=True),
    Shape("gear", gear, cad=True, genus=7, view=(0.6, -0.8, 1.2), up=Z_UP, thin=True),
)}


@functools.cache
def load(name):
    """The clean mesh of shape ``name``, centred on its bounding box, longest side 1.

    The mesh is cached and shared between callers: do not modify it.

    Raises
    ------
    KeyError
        For a name neither in ``SHAPES`` nor in ``FINE_PASS_CAD`` nor ``procedural-SEED``.
    """
    if name.startswith("procedural-"):
        mesh = procedural(int(name.removeprefix("procedural-")))
    else:
        mesh = (SHAPES[name].build if name in SHAPES else FINE_PASS_CAD[name])()
    lo, hi = mesh.bounds
    mesh.apply_translation(-(lo + hi) / 2)
    mesh.apply_scale(1.0 / (hi - lo).max())
    return mesh
