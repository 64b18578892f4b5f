"""The routing corpus: inputs whose answer is known, to measure what the default decides to run.

Every case is a noisy (or clean) mesh with its clean truth and the treatment it needs:

- ``none``: a clean mesh; it must come back as it was. The benchmark's shapes, the shared meshes,
  the literature's and the published clean meshes, coarse low-poly meshes (an icosphere, prisms, a
  torus, decimated animals and a bone), CAD parts exported as STL (every triangle's corners stored
  apart) and clean depth scans; low-poly insects modelled of primitives (tuning); and the real models
  bundled with the installed packages (`REAL_MODELS`: PyVista's and MeshLab's examples, low-poly
  characters, CAD, scans), all held aside: what users bring.
- ``fine``: noise below the skeleton's scale, to be smoothed on the mesh itself: Gaussian vertex noise
  (the literature's pairs, the published pairs, our own on other shapes) as OBJ, as STL and
  decimated; depth-camera scans (low-frequency waves, quantized depth, flare: `depth_scan`) and the
  shared Kinect scan; impulsive noise (a share of the vertices thrown off the surface).
- ``skeleton``: the thesis' bumps (§7.2) standing several voxels above the surface, as a
  marching-cubes mesh, decimated (as ``skelfilter compare`` hands it to MeshLab) and remeshed.

The cases of `HELD_ASIDE` shapes, and every real or published scan, form the held-aside split: they are
reported apart and never looked at while choosing. Meshes are cached under ``benchmark-cache/routing``.
"""

import functools
import importlib.util
import os
import tempfile
from dataclasses import dataclass

import numpy as np
import trimesh

from benchmarks import shapes
from benchmarks.depth_scan import depth_scan
from skelfilter.io import mesh_files
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.params import NoiseParams

ROOT = shapes.ROOT
SHARED = os.path.join(os.path.dirname(ROOT), "shared", "data")
LITERATURE = os.path.join(ROOT, "benchmarks", "data", "literature")
SOTA = os.path.join(ROOT, "benchmarks", "data", "sota")
CACHE = os.path.join(ROOT, "benchmark-cache", "routing")
TUNING = ("fandisk", "cube", "block", "bunny", "airplane", "quadruped", "mug", "u-channel", "pocket-plate")
HELD_ASIDE = ("rocker-arm", "spot", "twelve", "l-bracket", "fin-plate", "chair", "stool", "gear")
NEEDS = ("none", "fine", "skeleton")
# Real clean models bundled with the installed packages: (package, path in it); a case whose package is
# not installed is left out.
REAL_MODELS = (("pyvista", "examples/ant.ply"), ("pyvista", "examples/airplane.ply"), ("pyvista", "examples/nut.ply"),
               ("pyvista", "examples/sphere.ply"), ("pyvista", "examples/globe.vtk"),
               ("pyvista", "examples/hexbeam.vtk"),
               ("pymeshlab", "tests/sample_meshes/cow.obj"), ("pymeshlab", "tests/sample_meshes/cube.obj"),
               ("pymeshlab", "tests/sample_meshes/airplane.obj"),
               ("pymeshlab", "tests/sample_meshes/colored_airplane.ply"),
               ("pymeshlab", "tests/sample_meshes/bunny10k_textured.obj"),
               ("pymeshlab", "tests/sample_meshes/bunny.obj"), ("pymeshlab", "tests/sample_meshes/bone.ply"),
               ("pymeshlab", "tests/sample_meshes/rangemaps/face000.ply"))


@dataclass(frozen=True)
class Case:
    """One input of the corpus: ``make() -> (input mesh, clean mesh)``."""

    name: str
    kind: str  # what the input is: clean, coarse, stl, gaussian, depth-scan, kinect, impulsive, thesis-noise...
    needs: str  # one of NEEDS
    split: str  # "tuning" or "held-aside"
    make: object
    storage: str = "indexed"  # how the file stores its vertices: indexed, stl (corners apart), decimated...


def _split(shape):
    return "tuning" if shape in TUNING else "held-aside"


def _as_stl(mesh):
    """``mesh`` written as binary STL and read back as skelfilter reads files (corners apart)."""
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "mesh.stl")
        mesh.export(path)
        return mesh_files.load_mesh(path)


def _decimated(mesh, share):
    """Quadric edge collapse to ``share`` of the faces (open3d), as ``skelfilter compare`` decimates."""
    from skelfilter.evaluation.comparison.run import decimate

    return decimate(mesh, max(int(len(mesh.faces) * share), 4))


def _remeshed(mesh, edge_voxels, pitch):
    """Isotropic remeshing (MeshLab) to edges of about ``edge_voxels`` voxels of ``pitch``."""
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(np.asarray(mesh.vertices), np.asarray(mesh.faces)))
    ms.meshing_isotropic_explicit_remeshing(iterations=4, targetlen=pymeshlab.PureValue(edge_voxels * pitch))
    m = ms.current_mesh()
    return trimesh.Trimesh(m.vertex_matrix(), m.face_matrix(), process=False)


def _vertex_normals(mesh):
    merged = mesh.copy()
    merged.merge_vertices()
    return merged.vertex_normals[np.unique(np.asarray(mesh.vertices), axis=0, return_inverse=True)[1].reshape(-1)]


def gaussian_noise(mesh, sigma_edges, seed, along_normal=True):
    """Gaussian vertex noise of ``sigma_edges`` mean edge lengths, along the normals or in any direction."""
    rng = np.random.default_rng(seed)
    edge = float(mesh.edges_unique_length.mean())
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    if along_normal:
        offset = _vertex_normals(mesh) * rng.normal(0.0, sigma_edges * edge, len(vertices))[:, None]
    else:
        offset = rng.normal(0.0, sigma_edges * edge, vertices.shape)
    return trimesh.Trimesh(vertices + offset, np.asarray(mesh.faces), process=False)


def impulsive_noise(mesh, share, height_edges, seed):
    """``share`` of the vertices thrown off the surface along their normals by up to ``height_edges``
    mean edge lengths (uniform in magnitude, random sign): spikes and pits."""
    rng = np.random.default_rng(seed)
    edge = float(mesh.edges_unique_length.mean())
    vertices = np.asarray(mesh.vertices, dtype=np.float64).copy()
    hit = rng.random(len(vertices)) < share
    size = rng.uniform(0.3, 1.0, hit.sum()) * height_edges * edge * rng.choice([-1.0, 1.0], hit.sum())
    vertices[hit] += _vertex_normals(mesh)[hit] * size[:, None]
    return trimesh.Trimesh(vertices, np.asarray(mesh.faces), process=False)


def _subdivided(name, faces):
    """The shape ``name`` with its long edges split until it has at least ``faces`` faces (for vertex
    noise, which needs vertices on the flat faces)."""
    mesh = shapes.load(name)
    edge = 1.5 * np.sqrt(4.0 * mesh.area / (np.sqrt(3.0) * faces))  # an equilateral mesh's edge, and some
    vertices, tris = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=edge)
    return trimesh.Trimesh(vertices, tris, process=True)


def _thesis_noise(name, seed):
    clean = shapes.load(name)
    noisy, _, _ = mesh_pipeline.noisy_mesh(clean, NoiseParams(resolution=160, seed=seed, p=0.014, r=2.1, h=3, l=6))
    return noisy, clean


def _coarse(mesh, faces):
    """A clean low-poly version of ``mesh``: decimated to ``faces`` faces."""
    return _decimated(mesh, faces / len(mesh.faces))


def _bone(segments):
    """A bone: a shaft with two knobs at each end, ``segments`` around."""
    import manifold3d

    shaft = manifold3d.Manifold.cylinder(0.8, 0.07, -1.0, segments).translate((0, 0, -0.4))
    knobs = [manifold3d.Manifold.sphere(0.11, segments).translate((x, 0, z))
             for z in (-0.42, 0.42) for x in (-0.07, 0.07)]
    return shapes._to_trimesh(manifold3d.Manifold.batch_boolean([shaft] + knobs, manifold3d.OpType.Add))


def _insect(segments):
    """A low-poly insect modelled of primitives: three body segments (ellipsoids, ``segments`` around),
    six bent legs and two antennae (six-sided cylinders)."""
    import manifold3d

    parts = [manifold3d.Manifold.sphere(1.0, segments).scale(size).translate(centre)
             for size, centre in (((0.35, 0.25, 0.22), (-0.55, 0, 0)), ((0.25, 0.18, 0.16), (0, 0, 0)),
                                  ((0.2, 0.17, 0.15), (0.4, 0, 0.05)))]

    def limb(start, end, radius):
        start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
        length = float(np.linalg.norm(end - start))
        axis = (end - start) / length
        tilt, turn = np.degrees(np.arccos(axis[2])), np.degrees(np.arctan2(axis[1], axis[0]))
        return (manifold3d.Manifold.cylinder(length, radius, radius, 6).rotate((0, tilt, 0)).rotate((0, 0, turn))
                .translate(tuple(start)))

    for x in (-0.15, 0.0, 0.15):
        for side in (-1, 1):
            knee = (1.6 * x, 0.45 * side, 0.15)
            parts += [limb((x, 0, 0), knee, 0.03), limb(knee, (2.2 * x, 0.7 * side, -0.35), 0.025)]
    parts += [limb((0.5, 0.05 * side, 0.12), (0.8, 0.3 * side, 0.4), 0.015) for side in (-1, 1)]
    return shapes._to_trimesh(manifold3d.Manifold.batch_boolean(parts, manifold3d.OpType.Add))


def _real(path):
    """A maker of ``(model, model)`` from a mesh file: VTK files through PyVista, the others as skelfilter
    reads them."""
    def make():
        if path.endswith(".vtk"):
            import pyvista

            surface = pyvista.read(path).extract_surface().triangulate()
            mesh = trimesh.Trimesh(surface.points, surface.faces.reshape(-1, 4)[:, 1:], process=False)
        else:
            mesh = mesh_files.load_mesh(path)
        return mesh, mesh
    return make


def _then(make, transform):
    """A maker of ``(transform(input), clean)`` from a maker of ``(input, clean)``."""
    def made():
        mesh, clean = make()
        return transform(mesh), clean
    return made


def _pair(folder):
    def make():
        return (mesh_files.load_mesh(os.path.join(folder, "noisy.obj")),
                mesh_files.load_mesh(os.path.join(folder, "clean.obj")))
    return make


def _clean(folder):
    def make():
        clean = mesh_files.load_mesh(os.path.join(folder, "clean.obj"))
        return clean, clean
    return make


def _cases():
    cases = []
    add = cases.append
    # clean inputs: must come back as they were
    for name in shapes.SHAPES:
        add(Case(f"{name}", "clean", "none", _split(name), lambda n=name: (shapes.load(n), shapes.load(n))))
    for name in ("fandisk", "block", "l-bracket", "gear"):
        add(Case(f"{name}.stl", "clean", "none", _split(name),
                 _then(lambda n=name: (shapes.load(n), shapes.load(n)), _as_stl), storage="stl"))
    for folder in ("Fandisk0.3", "Nicolo0.2", "Bunny0.2"):
        add(Case(f"lit-{folder}-clean", "clean", "none", "held-aside" if "Nicolo" in folder else "tuning",
                 _clean(os.path.join(LITERATURE, folder))))
    for folder in ("gcn-trimstar-n3", "tgv-block"):
        add(Case(f"sota-{folder}-clean", "clean", "none", "held-aside", _clean(os.path.join(SOTA, folder))))
    coarse = {
        "icosphere-80": (lambda: trimesh.creation.icosphere(1), "tuning"),
        "icosphere-320": (lambda: trimesh.creation.icosphere(2), "tuning"),
        "octagonal-prism": (lambda: trimesh.creation.cylinder(0.3, 1.0, sections=8), "tuning"),
        "torus-lowpoly": (lambda: trimesh.creation.torus(1.0, 0.35, major_sections=16, minor_sections=8), "held-aside"),
        "capsule-lowpoly": (lambda: trimesh.creation.capsule(1.0, 0.3, count=[8, 8]), "held-aside"),
        "quadruped-600": (lambda: _coarse(shapes.load("quadruped"), 600), "tuning"),
        "bunny-1000": (lambda: _coarse(shapes.load("bunny"), 1000), "tuning"),
        "spot-800": (lambda: _coarse(shapes.load("spot"), 800), "held-aside"),
        "airplane-400": (lambda: _coarse(shapes.load("airplane"), 400), "tuning"),
        "bone-12": (lambda: _bone(12), "held-aside"),
        "bone-lowpoly-300": (lambda: _coarse(_bone(24), 300), "held-aside"),
        "chair-decimated": (lambda: _coarse(shapes.load("chair"), 2000), "held-aside"),
    }
    for name, (build, split) in coarse.items():
        add(Case(name, "coarse", "none", split, lambda b=build: (b(), b())))
    for segments in (8, 12):
        add(Case(f"insect-{segments}", "low-poly", "none", "tuning", lambda s=segments: (_insect(s),) * 2))
    for package, path in REAL_MODELS:
        spec = importlib.util.find_spec(package)
        file = os.path.join(os.path.dirname(spec.origin), path) if spec is not None else ""
        if os.path.isfile(file):
            add(Case(f"{package}-{os.path.basename(file)}", "real", "none", "held-aside", _real(file),
                     storage=file.rsplit(".", 1)[1]))
    for name in ("fandisk", "bunny", "spot", "rocker-arm"):
        add(Case(f"{name}-depth-truth", "clean-scan", "none", _split(name),
                 lambda n=name: (depth_scan(shapes.load(n), seed=2)[1],) * 2))
    # fine noise: smoothed on the mesh itself
    for folder in ("Fandisk0.3", "Fandisk0.7", "Bunny0.2", "Nicolo0.2"):
        split = "held-aside" if folder in ("Nicolo0.2", "Fandisk0.7") else "tuning"
        make = _pair(os.path.join(LITERATURE, folder))
        add(Case(f"lit-{folder}", "gaussian", "fine", split, make))
        add(Case(f"lit-{folder}.stl", "gaussian", "fine", split, _then(make, _as_stl), storage="stl"))
        add(Case(f"lit-{folder}-decimated", "gaussian", "fine", split,
                 _then(make, lambda m: _decimated(m, 0.5)), storage="decimated"))
    for folder in ("gcn-trimstar-n3", "tgv-block"):
        add(Case(f"sota-{folder}", "gaussian", "fine", "held-aside", _pair(os.path.join(SOTA, folder))))
    for name, sigma, normal in (("rocker-arm", 0.3, True), ("spot", 0.2, False), ("quadruped", 0.25, True),
                                ("gear", 0.3, False), ("mug", 0.15, True), ("l-bracket", 0.2, True)):
        def make(n=name, s=sigma, a=normal):
            clean = _subdivided(n, 20_000)
            return gaussian_noise(clean, s, seed=1, along_normal=a), clean
        add(Case(f"{name}-gaussian-{sigma}", "gaussian", "fine", _split(name), make))
    for name, seed in (("fandisk", 1), ("block", 2), ("bunny", 3), ("quadruped", 4), ("spot", 5), ("l-bracket", 6),
                       ("rocker-arm", 7)):
        add(Case(f"{name}-depth-scan", "depth-scan", "fine", _split(name),
                 lambda n=name, s=seed: depth_scan(shapes.load(n), seed=s)))
    kinect = os.path.join(SHARED, "realscan", "kinect-pyramid")
    add(Case("kinect-pyramid", "kinect", "fine", "held-aside", _pair(kinect)))
    add(Case("kinect-pyramid.stl", "kinect", "fine", "held-aside", _then(_pair(kinect), _as_stl), storage="stl"))
    add(Case("twelve-impulsive", "impulsive", "fine", "held-aside",
             _pair(os.path.join(ROOT, "skelfilter", "data", "twelve-impulsive"))))
    for name, share, height in (("fandisk", 0.1, 1.5), ("bunny", 0.05, 2.0), ("rocker-arm", 0.1, 1.0),
                                ("spot", 0.2, 1.0)):
        def make(n=name, s=share, h=height):
            clean = _subdivided(n, 20_000)
            return impulsive_noise(clean, s, h, seed=1), clean
        add(Case(f"{name}-impulsive-{share}", "impulsive", "fine", _split(name), make))
    # skeleton-scale noise: the voxel stage
    for name in ("fandisk", "cube", "bunny", "airplane", "rocker-arm", "twelve", "l-bracket", "chair"):
        make = functools.partial(_thesis_noise, name, 1)
        add(Case(f"{name}-thesis", "thesis-noise", "skeleton", _split(name), make, storage="marching-cubes"))
        add(Case(f"{name}-thesis-decimated", "thesis-noise", "skeleton", _split(name),
                 _then(make, lambda m: _decimated(m, 60_000 / len(m.faces))), storage="decimated"))
    for name in ("fandisk", "bunny", "spot", "gear"):
        make = functools.partial(_thesis_noise, name, 2)
        add(Case(f"{name}-thesis-remeshed", "thesis-noise", "skeleton", _split(name),
                 _then(make, lambda m: _remeshed(m, 2.0, 1.0 / 160)), storage="remeshed"))
    return cases


CASES = {case.name: case for case in _cases()}


def load(name):
    """(input, clean) of case ``name``, cached as PLY files under `CACHE`."""
    folder = os.path.join(CACHE, name)
    paths = [os.path.join(folder, f"{part}.ply") for part in ("input", "clean")]
    if all(os.path.isfile(p) for p in paths):
        return tuple(trimesh.load(p, process=False) for p in paths)
    case = CASES[name]
    meshes = case.make()
    os.makedirs(folder, exist_ok=True)
    for mesh, path in zip(meshes, paths):
        mesh.export(path)
    # as read back: the first run and every later one denoise the same vertices (a PLY's are float32)
    return tuple(trimesh.load(p, process=False) for p in paths)
