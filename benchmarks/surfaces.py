"""Surfaces from label maps: skelfilter's mesh of a label map against the surfaces a segmentation user
already has, scored against the analytic solid the label map samples.

    python -m benchmarks.surfaces [--set tuning|held-out|all] [--methods a,b] [--oracle] [--out surface-output]

Each case is an analytic solid (exact signed distance in millimetres) sampled as a label map: a voxel
is set where its centre lies inside. Spacings are isotropic and thick-sliced (slices two or more times
as thick as the in-plane pixels), the solids placed at a random sub-voxel offset and turned off the
axes. ``noise``: a quarter of the boundary voxels (either side of the surface, 6-neighbours across it)
flipped at random. Every method meshes the same label map in world millimetres:

- ``marching cubes``: scikit-image's of the mask at one half (no smoothing);
- ``slicer``: 3D Slicer's closed-surface export (discrete flying edges, then windowed-sinc smoothing
  with Slicer's default smoothing factor 0.5: pass band 10**(-4 * 0.5), 20 iterations, non-manifold
  smoothing on, coordinates normalized; ``vtkBinaryLabelmapToClosedSurfaceConversionRule``);
- ``surface nets``: VTK's ``vtkSurfaceNets3D`` with its own constrained smoothing (defaults);
- ``skelfilter``: ``skelfilter denoise seg.nii.gz out.ply --label 1``, no flags (the file written and
  read back, as a user runs it).

``--oracle`` adds the column ``true distance``: marching cubes of the solid's exact signed distance at the
same voxel centres, the best any marching cubes of that grid can do (its triangles are chords of the
surface: a part a few voxels thick loses volume even there).

Scores: ``distance`` (mm, the mean of the mean distance from the mesh to the true surface and from the
true surface to the mesh), ``normal_error`` (degrees, area-weighted mean angle between the mesh's face
normals and the true surface's normal at the same place), ``volume_error`` (% of the true volume),
``thin_kept`` (the share of points along a thin solid's axis that lie inside the mesh), and the mesh's
soundness: ``manifold`` (every edge on two faces, consistently wound), ``pieces`` (connected pieces),
``zero_area`` (faces without area). Writes ``results.json`` and ``table.md`` into ``--out``
(``--pictures``: also ``pictures.png``). ``--frog``: pyvista's frog tissue map instead, every label at
once (shared boundaries measured along every grid edge between touching labels) and what the default
changes of each label (``frog.json``, ``frog.png``; about ten minutes).
"""

import argparse
import json
import os
import sys
import tempfile
import time

import numpy as np
import trimesh
from scipy import ndimage
from skimage import measure

from skelfilter.mesh.closest_points import MeshSurface

BOUNDARY_FLIP = 0.25  # share of the boundary voxels flipped by ``noise``
SAMPLES = 40_000  # surface samples per mesh for the scores
MARGIN_MM = 4.0  # around each solid on its grid


# --- the analytic solids: signed distance in mm, < 0 inside ---------------------------------------

def _rotation(seed):
    """A fixed rotation turning a solid off the grid's axes."""
    rng = np.random.default_rng(seed)
    q = rng.standard_normal(4)
    return trimesh.transformations.quaternion_matrix(q / np.linalg.norm(q))[:3, :3]


def ball(radius):
    return {"sdf": lambda p: np.linalg.norm(p, axis=1) - radius, "extent": radius,
            "volume": 4 / 3 * np.pi * radius**3, "axis": None}


def torus(major, minor, seed=3):
    rot = _rotation(seed)

    def sdf(p):
        q = p @ rot
        return np.hypot(np.hypot(q[:, 0], q[:, 1]) - major, q[:, 2]) - minor
    angles = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    axis = np.stack([major * np.cos(angles), major * np.sin(angles), 0 * angles], axis=1) @ rot.T
    return {"sdf": sdf, "extent": major + minor, "volume": 2 * np.pi**2 * major * minor**2,
            "axis": axis if minor <= 3.5 else None}


def rod(radius, length, direction=(1.0, 0.55, 0.8)):
    """A capsule: the points within ``radius`` of a segment of ``length`` (a vessel)."""
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    a, b = -d * length / 2, d * length / 2

    def sdf(p):
        t = np.clip((p - a) @ d, 0, length)
        return np.linalg.norm(p - (a + t[:, None] * d), axis=1) - radius
    axis = a + np.linspace(0.1, 0.9, 200)[:, None] * (b - a)
    return {"sdf": sdf, "extent": length / 2 + radius,
            "volume": np.pi * radius**2 * length + 4 / 3 * np.pi * radius**3, "axis": axis}


def box(sides, seed=5):
    rot, half = _rotation(seed), np.asarray(sides, dtype=float) / 2

    def sdf(p):
        q = np.abs(p @ rot) - half
        return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0)
    return {"sdf": sdf, "extent": float(np.linalg.norm(half)), "volume": float(np.prod(sides)), "axis": None}


def cylinder(radius, height, seed=7):
    rot = _rotation(seed)

    def sdf(p):
        q = p @ rot
        d = np.stack([np.hypot(q[:, 0], q[:, 1]) - radius, np.abs(q[:, 2]) - height / 2], axis=1)
        return np.linalg.norm(np.maximum(d, 0), axis=1) + np.minimum(d.max(axis=1), 0)
    return {"sdf": sdf, "extent": float(np.hypot(radius, height / 2)), "volume": np.pi * radius**2 * height,
            "axis": None}


SOLIDS = {
    "ball": lambda: ball(11.0),
    "torus": lambda: torus(13.0, 5.0),
    "rod": lambda: rod(3.0, 44.0),
    # held out: sharp edges, a bent vessel, a plate-like box
    "box": lambda: box((22.0, 16.0, 12.0)),
    "cylinder": lambda: cylinder(8.0, 20.0),
    "bent vessel": lambda: torus(14.0, 2.5, seed=11),
    "plate": lambda: box((30.0, 24.0, 5.0), seed=13),
}
# spacings in mm: isotropic, thick slices; the rod's radius is three in-plane pixels
SPACINGS = {"iso": (1.0, 1.0, 1.0), "thick": (1.0, 1.0, 2.0), "thick-fine": (0.7, 0.7, 2.1),
            "thick-x": (2.5, 1.0, 1.0)}
SETS = {
    "tuning": [(s, sp) for s in ("ball", "torus", "rod") for sp in ("iso", "thick")],
    "held-out": [(s, sp) for s in ("box", "cylinder", "bent vessel", "plate", "rod", "torus")
                 for sp in ("thick-fine", "thick-x")],
}


def sampled_distance(solid, spacing, seed):
    """The solid's signed distance (mm, < 0 inside) at the voxel centres of its grid, the solid at a
    random sub-voxel offset: (values, affine)."""
    spacing = np.asarray(spacing, dtype=float)
    rng = np.random.default_rng(seed)
    half = solid["extent"] + MARGIN_MM
    shape = np.ceil(2 * half / spacing).astype(int) + 1
    origin = -half + rng.uniform(-0.5, 0.5, 3) * spacing
    ijk = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), axis=-1).reshape(-1, 3)
    affine = np.diag([*spacing, 1.0])
    affine[:3, 3] = origin
    return solid["sdf"](origin + ijk * spacing).reshape(shape), affine


def label_map(solid, spacing, seed):
    """The solid sampled at voxel centres: (mask, affine), the solid at a random sub-voxel offset."""
    values, affine = sampled_distance(solid, spacing, seed)
    return values < 0, affine


def true_distance_mesh(solid, spacing, seed):
    """The oracle: marching cubes of the solid's exact distance at the label map's voxel centres, the
    best surface a marching cubes of that grid can give (its triangles are chords: thin parts lose
    volume)."""
    from skelfilter.mesh.marching_cubes import field_to_world_mesh

    values, affine = sampled_distance(solid, spacing, seed)
    return field_to_world_mesh(-values.astype(np.float32), affine)


def boundary_noise(mask, seed):
    """``mask`` with `BOUNDARY_FLIP` of its boundary voxels (both sides of the surface) flipped."""
    boundary = (mask & ~ndimage.binary_erosion(mask)) | (ndimage.binary_dilation(mask) & ~mask)
    where = np.flatnonzero(boundary)
    flip = np.random.default_rng(seed).choice(where, int(BOUNDARY_FLIP * len(where)), replace=False)
    noisy = mask.copy().reshape(-1)
    noisy[flip] ^= True
    return noisy.reshape(mask.shape)


# --- the methods: (mask, affine) -> trimesh in world mm ---------------------------------------------

def _image(mask, affine, pad=1):
    import vtk
    from vtk.util import numpy_support

    padded = np.pad(mask.astype(np.uint8), pad)
    image = vtk.vtkImageData()
    image.SetDimensions(*padded.shape)
    image.SetSpacing(*np.diag(affine)[:3])
    image.SetOrigin(*(affine[:3, 3] - pad * np.diag(affine)[:3]))
    image.GetPointData().SetScalars(numpy_support.numpy_to_vtk(padded.ravel(order="F"), deep=True))
    return image


def _polydata_mesh(poly):
    import vtk
    from vtk.util import numpy_support

    tri = vtk.vtkTriangleFilter()
    tri.SetInputData(poly)
    tri.Update()
    poly = tri.GetOutput()
    vertices = numpy_support.vtk_to_numpy(poly.GetPoints().GetData()).astype(np.float64)
    faces = numpy_support.vtk_to_numpy(poly.GetPolys().GetConnectivityArray()).reshape(-1, 3)
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def marching_cubes(mask, affine):
    spacing = np.diag(affine)[:3]
    verts, faces, _, _ = measure.marching_cubes(np.pad(mask, 1).astype(np.float32), 0.5, spacing=tuple(spacing))
    mesh = trimesh.Trimesh(verts - spacing + affine[:3, 3], faces, process=False)
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def slicer(mask, affine, smoothing_factor=0.5):
    import vtk

    surface = vtk.vtkDiscreteFlyingEdges3D()
    surface.SetInputData(_image(mask, affine))
    surface.SetValue(0, 1)
    smoother = vtk.vtkWindowedSincPolyDataFilter()
    smoother.SetInputConnection(surface.GetOutputPort())
    smoother.SetNumberOfIterations(20)
    smoother.BoundarySmoothingOff()
    smoother.FeatureEdgeSmoothingOff()
    smoother.SetFeatureAngle(120.0)
    smoother.SetPassBand(10 ** (-4.0 * smoothing_factor))
    smoother.NonManifoldSmoothingOn()
    smoother.NormalizeCoordinatesOn()
    smoother.Update()
    return _polydata_mesh(smoother.GetOutput())


def surface_nets(mask, affine):
    import vtk

    nets = vtk.vtkSurfaceNets3D()
    nets.SetInputData(_image(mask, affine))
    nets.SetLabel(0, 1)
    nets.SetOutputMeshTypeToTriangles()
    nets.Update()
    return _polydata_mesh(nets.GetOutput())


def skelfilter_cli(mask, affine):
    """``skelfilter denoise seg.nii.gz out.ply --label 1`` through the same function the CLI calls."""
    import nibabel

    from skelfilter.jobs.denoise_file import denoise_file
    from skelfilter.params import DenoiseParams, VolumeParams

    with tempfile.TemporaryDirectory() as folder:
        volume, out = os.path.join(folder, "seg.nii.gz"), os.path.join(folder, "out.ply")
        nibabel.save(nibabel.Nifti1Image(mask.astype(np.uint8), affine), volume)
        denoise_file(volume, out, DenoiseParams(), VolumeParams(label=1))
        return trimesh.load(out, process=False)


METHODS = {"marching cubes": marching_cubes, "slicer": slicer, "surface nets": surface_nets,
           "skelfilter": skelfilter_cli}


# --- the scores ---------------------------------------------------------------------------------------

def _gradient(sdf, points, step=1e-4):
    grad = np.stack([(sdf(points + e) - sdf(points - e)) / (2 * step) for e in np.eye(3) * step], axis=1)
    return grad / np.maximum(np.linalg.norm(grad, axis=1, keepdims=True), 1e-12)


def true_surface_samples(solid, count, seed=0):
    """Points on the true surface: a fine marching cubes of the signed distance, projected onto it."""
    half = solid["extent"] + 1.0
    n = 161
    axis = np.linspace(-half, half, n)
    pts = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), axis=-1).reshape(-1, 3)
    values = solid["sdf"](pts).reshape(n, n, n)
    verts, faces, _, _ = measure.marching_cubes(values, 0.0, spacing=(axis[1] - axis[0],) * 3)
    fine = trimesh.Trimesh(verts - half, faces, process=False)
    points, _ = trimesh.sample.sample_surface(fine, count, seed=seed)
    for _ in range(3):
        points = points - solid["sdf"](points)[:, None] * _gradient(solid["sdf"], points)
    return points


def _inside(mesh, points):
    """Whether each point lies inside the closed mesh (open3d's ray-casting occupancy)."""
    import open3d as o3d

    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, dtype=np.float32)),
                        o3d.core.Tensor(np.asarray(mesh.faces, dtype=np.uint32)))
    return scene.compute_occupancy(o3d.core.Tensor(np.asarray(points, dtype=np.float32))).numpy() > 0.5


def score(mesh, solid, truth):
    sdf = solid["sdf"]
    points, faces = trimesh.sample.sample_surface(mesh, SAMPLES, seed=1)
    forward = np.abs(sdf(points)).mean()
    backward = MeshSurface(mesh).distance(truth.astype(np.float32)).mean()
    cos = np.einsum("ij,ij->i", mesh.face_normals[faces], _gradient(sdf, points))
    row = {"distance": float((forward + backward) / 2),
           "normal_error": float(np.degrees(np.arccos(np.clip(cos, -1, 1))).mean()),
           "volume_error": float(100 * (mesh.volume - solid["volume"]) / solid["volume"]),
           "manifold": bool(mesh.is_watertight and mesh.is_winding_consistent),
           "pieces": len(trimesh.graph.connected_components(mesh.face_adjacency, nodes=np.arange(len(mesh.faces)))),
           "zero_area": int(np.count_nonzero(mesh.area_faces <= 1e-12 * mesh.scale**2))}
    if solid["axis"] is not None:
        row["thin_kept"] = float(_inside(mesh, solid["axis"]).mean())
    return row


def interface_gaps(labels, affine, meshes):
    """Where two labels' voxels touch: along each grid edge from a voxel of label A to a 6-neighbour of
    label B, the distance between where A's surface and B's surface cross it (world units; 0 where
    they share the boundary). Returns ``{(A, B): distances}``."""
    import open3d as o3d

    scenes = {}
    for label, mesh in meshes.items():
        scene = o3d.t.geometry.RaycastingScene()
        scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, dtype=np.float32)),
                            o3d.core.Tensor(np.asarray(mesh.faces, dtype=np.uint32)))
        scenes[label] = scene
    gaps = {}
    for axis in range(3):
        lo = labels[tuple(slice(None, -1) if a == axis else slice(None) for a in range(3))]
        hi = labels[tuple(slice(1, None) if a == axis else slice(None) for a in range(3))]
        touch = (lo != hi) & (lo != 0) & (hi != 0) & np.isin(lo, list(meshes)) & np.isin(hi, list(meshes))
        start = np.argwhere(touch).astype(float)
        step = affine[:3, axis]
        origins = start @ affine[:3, :3].T + affine[:3, 3]
        rays = o3d.core.Tensor(np.hstack([origins, np.tile(step, (len(origins), 1))]).astype(np.float32))
        a_labels, b_labels = lo[touch], hi[touch]
        hits = {}
        for label in np.unique(np.concatenate([a_labels, b_labels])):
            hits[int(label)] = scenes[int(label)].cast_rays(rays)["t_hit"].numpy()
        # t in units of the step (one voxel along the axis): the first crossing from the lower voxel
        t_a = np.choose(np.searchsorted(sorted(hits), a_labels), [hits[k] for k in sorted(hits)])
        t_b = np.choose(np.searchsorted(sorted(hits), b_labels), [hits[k] for k in sorted(hits)])
        distance = np.abs(t_a - t_b) * np.linalg.norm(step)
        for pair in {tuple(sorted((int(a), int(b)))) for a, b in zip(a_labels, b_labels)}:
            sel = ((a_labels == pair[0]) & (b_labels == pair[1])) | ((a_labels == pair[1]) & (b_labels == pair[0]))
            gaps.setdefault(pair, []).append(distance[sel])
    return {pair: np.concatenate(parts) for pair, parts in gaps.items()}


def run_case(solid_name, spacing_name, noisy, methods, seed):
    solid = SOLIDS[solid_name]()
    mask, affine = label_map(solid, SPACINGS[spacing_name], seed)
    if noisy:
        mask = boundary_noise(mask, seed)
    truth = true_surface_samples(solid, SAMPLES)
    rows = {}
    for name in methods:
        start = time.perf_counter()
        if name == ORACLE:
            mesh = true_distance_mesh(solid, SPACINGS[spacing_name], seed)
        else:
            mesh = METHODS[name](mask, affine)
        rows[name] = {**score(mesh, solid, truth), "seconds": time.perf_counter() - start,
                      "faces": len(mesh.faces)}
    return {"solid": solid_name, "spacing": spacing_name, "noise": "boundary" if noisy else "clean",
            "voxels": int(mask.sum()), "methods": rows}


ORACLE = "true distance"  # `true_distance_mesh`: a column of the table, not a method of a label map


PICTURE_CASES = (("torus", "thick", False), ("rod", "thick", False), ("bent vessel", "thick-fine", False),
                 ("ball", "iso", True), ("rod", "iso", True))


def pictures(methods, path, seed=1, cases=PICTURE_CASES):
    """One row per case, one panel per method, each case framed by its true solid's box; a PNG."""
    from matplotlib.figure import Figure

    from skelfilter.evaluation import camera, figures

    fig = Figure(figsize=(3.2 * len(methods), 3.2 * len(cases)), dpi=100)
    for row, (solid_name, spacing_name, noisy) in enumerate(cases):
        solid = SOLIDS[solid_name]()
        mask, affine = label_map(solid, SPACINGS[spacing_name], seed)
        if noisy:
            mask = boundary_noise(mask, seed)
        half = solid["extent"]
        bounds = np.array([[-half] * 3, [half] * 3])
        for col, name in enumerate(methods):
            ax = fig.add_subplot(len(cases), len(methods), row * len(methods) + col + 1, projection="3d")
            figures.draw_mesh(ax, METHODS[name](mask, affine), camera.direction_from_angles(25, -60), bounds=bounds)
            title = f"{solid_name} {spacing_name}{' noisy' if noisy else ''}: {name}" if col == 0 else name
            ax.set_title(title, fontsize=8)
    fig.tight_layout()
    fig.savefig(path)


def frog(out, picture_labels=(5,)):
    """Pyvista's frog tissue map (shipped with pyvista): every label's surface at once, the distance
    between touching labels' surfaces along every grid edge between them, and what the default changes
    of each label; writes ``frog.json`` and ``frog.png`` (a label: voxels, smooth surface, default)."""
    import pyvista.examples

    from skelfilter.core import pipeline
    from skelfilter.evaluation import camera, figures
    from skelfilter.io.volume_files import load_volume
    from skelfilter.mesh import marching_cubes

    path = os.path.join(os.path.dirname(pyvista.examples.__file__), "frog_tissues.vti")
    volume = load_volume(path)
    start = time.perf_counter()
    meshes = marching_cubes.labels_to_world_meshes(volume.data, volume.affine)
    seconds = time.perf_counter() - start
    gaps = np.concatenate(list(interface_gaps(volume.data, volume.affine, meshes).values()))
    changed = {}
    for label in meshes:
        mask = volume.data == label
        changed[label] = (int(mask.sum()), pipeline.denoise_volume(mask, spacing=volume.spacing).voxels_changed)
    row = {"labels": len(meshes), "seconds": seconds, "edges": len(gaps), "largest_gap_mm": float(gaps.max()),
           "closed": sum(m.is_watertight and m.is_winding_consistent for m in meshes.values()),
           "zero_area": sum(int((m.area_faces <= 1e-12).sum()) for m in meshes.values()),
           "changed_by_default": {str(k): v for k, v in changed.items()}}
    with open(os.path.join(out, "frog.json"), "w") as f:
        json.dump(row, f, indent=1)
    panels, titles = [], []
    for label in picture_labels:
        mask = volume.data == label
        denoised = pipeline.denoise_volume(mask, spacing=volume.spacing).mask
        panels += [marching_cubes.mask_to_world_mesh(mask, volume.affine, smooth=False),
                   marching_cubes.mask_to_world_mesh(mask, volume.affine),
                   marching_cubes.mask_to_world_mesh(denoised, volume.affine)]
        titles += [f"label {label}: voxels", f"label {label}: smooth surface", f"label {label}: denoised, smooth"]
    figures.save_panels(panels, titles, os.path.join(out, "frog.png"), camera.direction_from_angles(30, -50))
    return row


def table(results, methods):
    head = "| case | " + " | ".join(methods) + " |"
    lines = [head, "|" + "---|" * (len(methods) + 1)]
    for r in results:
        cells = []
        for m in methods:
            s = r["methods"][m]
            flags = "" if s["manifold"] and s["pieces"] == 1 and s["zero_area"] == 0 else \
                f" ({'' if s['manifold'] else 'non-manifold, '}{s['pieces']} pieces, {s['zero_area']} zero-area)"
            thin = f" · {s['thin_kept']:.2f}" if "thin_kept" in s else ""
            cells.append(f"{s['normal_error']:.1f}° · {s['distance']:.3f} · {s['volume_error']:+.1f} %{thin}{flags}")
        lines.append(f"| {r['solid']} {r['spacing']} {r['noise']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--set", choices=[*SETS, "all"], default="all")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--solids", default=None, help="comma-separated, a subset of the set's")
    parser.add_argument("--noise", choices=("clean", "boundary", "both"), default="both")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--out", default="surface-output")
    parser.add_argument("--oracle", action="store_true",
                        help=f"also the {ORACLE!r} column: marching cubes of the exact distance on the same grid")
    parser.add_argument("--pictures", action="store_true", help="also draw a few cases (pictures.png)")
    parser.add_argument("--frog", action="store_true",
                        help="only pyvista's frog tissue map: every label at once (frog.json, frog.png)")
    args = parser.parse_args(argv)
    if args.frog:
        os.makedirs(args.out, exist_ok=True)
        row = frog(args.out)
        print(json.dumps({k: v for k, v in row.items() if k != "changed_by_default"}))
        print("labels the default changes:", {k: v for k, v in row["changed_by_default"].items() if v[1]})
        return 0
    methods = args.methods.split(",") + ([ORACLE] if args.oracle else [])
    sets = list(SETS) if args.set == "all" else [args.set]
    os.makedirs(args.out, exist_ok=True)
    results = []
    for set_name in sets:
        for solid, spacing in SETS[set_name]:
            if args.solids and solid not in args.solids.split(","):
                continue
            for noisy in {"clean": (False,), "boundary": (True,), "both": (False, True)}[args.noise]:
                r = {"set": set_name, **run_case(solid, spacing, noisy, methods, args.seed)}
                results.append(r)
                print(table([r], methods).splitlines()[-1], flush=True)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(results, f, indent=1)
    text = "normal error · mean distance (mm) · volume error · thin kept\n\n"
    for set_name in sets:
        text += f"\n## {set_name}\n\n" + table([r for r in results if r["set"] == set_name], methods) + "\n"
    with open(os.path.join(args.out, "table.md"), "w") as f:
        f.write(text)
    if args.pictures:
        pictures([m for m in methods if m != ORACLE], os.path.join(args.out, "pictures.png"), args.seed)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
