"""Tests of skelfilter.mesh.voxelize: the grid, exact shapes, and real open, unmerged and genus-1 meshes."""

from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy import ndimage as ndi
from scipy.spatial import ConvexHull
from skimage.measure import euler_number, marching_cubes

from skelfilter.core.neighbourhood import has_border_margin
from skelfilter.errors import InputError, ParameterError
from skelfilter.mesh import ray_votes
from skelfilter.mesh.voxelize import Grid, grid_for_bounds, voxelize, voxelize_on_grid

DATA = Path(__file__).parent / "data"
CUBE26 = np.ones((3, 3, 3), dtype=bool)


def load(name):
    packaged = resources.files("skelfilter") / "data" / name
    path = packaged if packaged.is_file() else DATA / name
    return trimesh.load(str(path), process=False)


def centres(grid):
    return grid.to_world(np.indices(grid.shape).reshape(3, -1).T)


def open3d_occupancy(mesh, points, nsamples):
    """Occupancy by open3d's ray casting (Embree), an independent implementation."""
    import open3d as o3d  # installed by the set-up (with libusb-1.0-0): a missing one must fail, not skip
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(
        o3d.core.Tensor(np.asarray(mesh.vertices, dtype=np.float32)),
        o3d.core.Tensor(np.asarray(mesh.faces, dtype=np.uint32)),
    )
    query = o3d.core.Tensor(np.asarray(points, dtype=np.float32))
    return scene.compute_occupancy(query, nsamples=nsamples).numpy().astype(bool)


def n_components(volume):
    return ndi.label(volume, CUBE26)[1]


def is_closed(volume):
    """No cavity: every background voxel reaches the border through face neighbours."""
    return bool((ndi.binary_fill_holes(volume) == volume).all())


# --- grid -------------------------------------------------------------------


def test_grid_is_centred_and_padded():
    bounds = np.array([[1.0, -2.0, 0.5], [5.0, 0.0, 1.5]])  # extents 4, 2, 1
    grid = grid_for_bounds(bounds, 32, 3)
    assert grid.pitch == 4 / 32
    assert grid.shape == (32 + 6, 16 + 6, 8 + 6)
    assert grid.n_voxels == 38 * 22 * 14
    cells_lo = grid.to_world([0, 0, 0]) - grid.pitch / 2
    cells_hi = grid.to_world(np.array(grid.shape) - 1) + grid.pitch / 2
    np.testing.assert_allclose(cells_lo, bounds[0] - 3 * grid.pitch)
    np.testing.assert_allclose(cells_hi, bounds[1] + 3 * grid.pitch)


def test_grid_rounds_short_sides_up_and_keeps_the_longest_exact():
    bounds = np.array([[0.0, 0.0, 0.0], [1.0, 0.3, 0.0]])  # a flat box: z has no extent
    grid = grid_for_bounds(bounds, 16, 2)
    assert grid.shape == (16 + 4, 5 + 4, 1 + 4)  # 0.3 * 16 = 4.8 -> 5 cells, z -> 1 cell
    cells_centre = grid.to_world((np.array(grid.shape) - 1) / 2)
    np.testing.assert_allclose(cells_centre, bounds.mean(axis=0), atol=1e-12)
    # Extents that are not exact in binary still give `resolution` voxels.
    for resolution in range(16, 700, 7):
        assert grid_for_bounds([[0, 0, 0], [0.3, 0.1, 0.7]], resolution, 0).shape[2] == resolution


def test_grid_round_trip_and_equality():
    grid = Grid([0.5, -1.0, 2.0], 0.25, (10, 20, 30))
    ijk = np.array([[0, 0, 0], [9, 19, 29], [1.5, 2.25, 3.0]])
    np.testing.assert_allclose(grid.to_index(grid.to_world(ijk)), ijk)
    np.testing.assert_allclose(grid.to_world([[2, 4, 4]]), [[1.0, 0.0, 3.0]])
    same = Grid(np.array([0.5, -1.0, 2.0]), 0.25, [10, 20, 30])
    assert grid == same and hash(grid) == hash(same)
    assert grid != Grid([0.5, -1.0, 2.5], 0.25, (10, 20, 30))


@pytest.mark.parametrize(
    "bounds, resolution, padding",
    [
        ([[0, 0, 0], [1, 1, 1]], 15, 2),
        ([[0, 0, 0], [1, 1, 1]], 32.0, 2),
        ([[0, 0, 0], [1, 1, 1]], 32, -1),
        ([[0, 0, 0], [0, 0, 0]], 32, 2),
        ([[0, 0, 0], [np.nan, 1, 1]], 32, 2),
        ([[0, 0, 0], [np.inf, 1, 1]], 32, 2),
        ([[1, 1, 1], [0, 2, 2]], 32, 2),
        ([0, 0, 0], 32, 2),
    ],
)
def test_grid_rejects_bad_parameters(bounds, resolution, padding):
    with pytest.raises(ParameterError):
        grid_for_bounds(bounds, resolution, padding)


def test_unusable_meshes_are_input_errors():
    box = trimesh.creation.box()
    grid = grid_for_bounds(box.bounds, 16, 1)
    for bad in (np.nan, np.inf):
        vertices = box.vertices.copy()
        vertices[3, 1] = bad
        mesh = trimesh.Trimesh(vertices, box.faces, process=False)
        with pytest.raises(InputError, match="NaN or infinite"):
            voxelize(mesh)
        with pytest.raises(InputError, match="NaN or infinite"):
            voxelize_on_grid(mesh, grid)
    with pytest.raises(InputError, match="no faces"):
        voxelize(trimesh.Trimesh())
    with pytest.raises(InputError, match="no faces"):
        voxelize(trimesh.Trimesh(box.vertices, np.zeros((0, 3), dtype=np.int64), process=False))
    with pytest.raises(InputError, match="coincide"):
        voxelize(trimesh.Trimesh(np.ones((3, 3)), [[0, 1, 2]], process=False))
    with pytest.raises(InputError, match="Trimesh"):
        voxelize(trimesh.Scene([box]))


# --- exact shapes -------------------------------------------------------------


def test_axis_aligned_box_is_exact():
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    volume, grid = voxelize(box, resolution=48, padding=4)
    assert grid.shape == volume.shape == (16 + 8, 32 + 8, 48 + 8)
    assert volume.dtype == bool
    assert volume.sum() == 16 * 32 * 48 == round(box.volume / grid.pitch**3)
    assert has_border_margin(volume, 4)
    assert volume[4:-4, 4:-4, 4:-4].all()


def test_rotated_box_matches_the_analytic_inside():
    extents = np.array([1.0, 1.5, 2.5])
    rotation = trimesh.transformations.rotation_matrix(0.7, [1.0, 2.0, 3.0], point=[0.1, 0.2, 0.3])
    box = trimesh.creation.box(extents=extents, transform=rotation)
    volume, grid = voxelize(box, resolution=64, padding=2)
    local = (centres(grid) - rotation[:3, 3]) @ rotation[:3, :3]
    expected = (np.abs(local) < extents / 2).all(axis=1).reshape(grid.shape)
    assert np.array_equal(volume, expected)
    assert volume.sum() * grid.pitch**3 == pytest.approx(box.volume, rel=5e-3)


def test_icosphere_matches_its_half_spaces_and_volume():
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    volume, grid = voxelize(sphere, resolution=80, padding=2)
    p = centres(grid)
    # Convex: inside iff behind every face plane.
    offsets = np.einsum("ij,ij->i", sphere.face_normals, sphere.triangles[:, 0])
    expected = np.ones(len(p), dtype=bool)
    for chunk in np.array_split(np.arange(len(p)), 16):
        expected[chunk] = (p[chunk] @ sphere.face_normals.T < offsets).all(axis=1)
    assert np.array_equal(volume, expected.reshape(grid.shape))
    assert volume.sum() * grid.pitch**3 == pytest.approx(sphere.volume, rel=2e-3)


@pytest.fixture(params=[True, False], ids=["nudged", "not-nudged"])
def nudge(request, monkeypatch):
    """Run with the sampling's sub-voxel nudge, and without it to test the exact tie rule alone."""
    if not request.param:
        monkeypatch.setattr(ray_votes, "_NUDGE", np.zeros(3))


def test_rays_exactly_through_vertices_and_edges(nudge):
    # An octahedron |x|+|y|+|z| < 10.5 whose vertices and edges lie on the
    # un-nudged rays: every crossing must still be counted exactly once.
    r = 10.5
    vertices = np.array([[r, 0, 0], [-r, 0, 0], [0, r, 0], [0, -r, 0], [0, 0, r], [0, 0, -r]])
    faces = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]]
    octahedron = trimesh.Trimesh(vertices, faces, process=False)
    grid = Grid([-12.0, -12.0, -12.0], 1.0, (25, 25, 25))
    volume = voxelize_on_grid(octahedron, grid)
    expected = np.abs(centres(grid)).sum(axis=1).reshape(grid.shape) < r
    assert np.array_equal(volume, expected)


def test_lattice_polytopes_are_exact(nudge):
    # Convex hulls of integer points shifted by half a voxel along one axis:
    # the rays along that axis run through vertices, the others along edges.
    rng = np.random.default_rng(7)
    grid = Grid([-10.0, -10.0, -10.0], 1.0, (21, 21, 21))
    c = centres(grid)
    for trial in range(30):
        points = rng.integers(-8, 9, size=(30, 3)).astype(float)
        points[:, trial % 3] += 0.5
        hull = ConvexHull(points)
        volume = voxelize_on_grid(trimesh.Trimesh(points, hull.simplices, process=False), grid)
        signed = c @ hull.equations[:, :3].T + hull.equations[:, 3]
        on_boundary = (np.abs(signed) < 1e-9).any(axis=1) & (signed < 1e-9).all(axis=1)
        expected = (signed < 0).all(axis=1)
        assert np.array_equal(volume.ravel()[~on_boundary], expected[~on_boundary])


def test_winding_and_vertex_sharing_do_not_matter():
    fandisk = load("fandisk.obj")
    volume, grid = voxelize(fandisk, resolution=64)
    rng = np.random.default_rng(0)
    faces = fandisk.faces.copy()
    flip = rng.random(len(faces)) < 0.5
    faces[flip] = faces[flip, ::-1]
    scrambled = trimesh.Trimesh(fandisk.vertices, faces[rng.permutation(len(faces))], process=False)
    corners = fandisk.triangles.reshape(-1, 3)  # every triangle with its own three vertices
    soup = trimesh.Trimesh(corners, np.arange(len(corners)).reshape(-1, 3), process=False)
    assert np.array_equal(voxelize_on_grid(scrambled, grid), volume)
    assert np.array_equal(voxelize_on_grid(soup, grid), volume)


def test_void_of_a_closed_mesh_stays_empty():
    outer = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    inner = trimesh.creation.icosphere(subdivisions=3, radius=0.5)
    inner.invert()  # a void's wall faces into the void
    shell = trimesh.util.concatenate([outer, inner])
    assert ray_votes.is_consistently_oriented(shell.vertices, shell.faces)
    volume, grid = voxelize(shell, resolution=64)
    void = ndi.binary_fill_holes(volume) & ~volume
    assert void.sum() * grid.pitch**3 == pytest.approx(-inner.volume, rel=0.02)
    assert volume.sum() * grid.pitch**3 == pytest.approx(outer.volume + inner.volume, rel=0.01)


def _union(*meshes):
    import manifold3d
    solid = sum((manifold3d.Manifold(manifold3d.Mesh(m.vertices.astype(np.float32), m.faces.astype(np.uint32)))
                 for m in meshes[1:]),
                manifold3d.Manifold(manifold3d.Mesh(meshes[0].vertices.astype(np.float32),
                                                    meshes[0].faces.astype(np.uint32))))
    out = solid.to_mesh()
    return trimesh.Trimesh(out.vert_properties[:, :3], out.tri_verts, process=False)


def test_overlapping_parts_give_their_union():
    a = trimesh.creation.box((2.0, 2.0, 2.0))
    b = trimesh.creation.box((2.0, 2.0, 2.0))
    b.apply_translation((1.0, 0.7, 0.5))
    c = trimesh.creation.icosphere(subdivisions=3, radius=0.8)
    c.apply_translation((-0.8, -0.5, 0.9))
    overlapping = trimesh.util.concatenate([a, b, c])
    grid = grid_for_bounds(overlapping.bounds, 64, 2)
    union = voxelize_on_grid(_union(a, b, c), grid)
    assert np.array_equal(voxelize_on_grid(overlapping, grid), union)
    overlapping.invert()  # inward-facing throughout: the winding number is -1, -2, ... and still nonzero
    assert np.array_equal(voxelize_on_grid(overlapping, grid), union)
    assert n_components(union) == 1 and is_closed(union)


def test_orientation_test_needs_a_closed_consistent_mesh():
    box = trimesh.creation.box()
    assert ray_votes.is_consistently_oriented(box.vertices, box.faces)
    flipped = box.faces.copy()
    flipped[0] = flipped[0, ::-1]
    assert not ray_votes.is_consistently_oriented(box.vertices, flipped)
    assert not ray_votes.is_consistently_oriented(box.vertices, box.faces[1:])
    corners = box.triangles.reshape(-1, 3)  # unmerged: coinciding vertices count as one
    assert ray_votes.is_consistently_oriented(corners, np.arange(len(corners)).reshape(-1, 3))


def test_open_tube_and_open_box_fill_like_the_closed_ones():
    capped = trimesh.creation.cylinder(radius=1.0, height=3.0, sections=64)
    sides = np.abs(capped.face_normals[:, 2]) < 0.5
    tube = trimesh.Trimesh(capped.vertices, capped.faces[sides], process=False)
    box = trimesh.creation.box(extents=(1.0, 1.2, 1.4))
    cup = trimesh.Trimesh(box.vertices, box.faces[box.face_normals[:, 2] < 0.5], process=False)
    for closed, open_ in ((capped, tube), (box, cup)):
        assert not open_.is_watertight
        volume, grid = voxelize(closed, resolution=64)
        assert np.array_equal(voxelize_on_grid(open_, grid), volume)


def test_grid_may_cover_part_of_the_mesh():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    grid = Grid([0.5, -0.2, -0.2], 0.02, (40, 20, 20))  # straddles the surface at x ~ 1
    volume = voxelize_on_grid(sphere, grid)
    offsets = np.einsum("ij,ij->i", sphere.face_normals, sphere.triangles[:, 0])
    expected = (centres(grid) @ sphere.face_normals.T < offsets).all(axis=1).reshape(grid.shape)
    assert 0 < volume.sum() < volume.size
    assert np.array_equal(volume, expected)
    huge = trimesh.creation.box(extents=(1e15, 1e15, 1e15))
    assert voxelize_on_grid(huge, grid).all()


# --- real meshes ----------------------------------------------------------------


def test_fandisk_agrees_with_open3d_ray_casting():
    fandisk = load("fandisk.obj")
    volume, grid = voxelize(fandisk, resolution=80, padding=2)
    reference = open3d_occupancy(fandisk, centres(grid), nsamples=3).reshape(grid.shape)
    assert (volume == reference).mean() >= 0.999
    assert n_components(volume) == 1 and is_closed(volume)
    assert euler_number(volume, connectivity=3) == 1


@pytest.mark.parametrize("resolution", [96, 200])
def test_open_bunny_is_one_closed_solid(resolution):
    bunny = load("stanford-bunny.obj")
    assert not bunny.is_watertight
    volume, grid = voxelize(bunny, resolution=resolution)
    assert n_components(volume) == 1
    assert is_closed(volume)
    assert has_border_margin(volume, 8)


def test_open_bunny_has_the_right_volume_and_no_tunnel():
    bunny = load("stanford-bunny.obj")
    volume, grid = voxelize(bunny, resolution=96)
    assert euler_number(volume, connectivity=3) == 1  # 1 component - 0 tunnels + 0 cavities
    # Independent estimate: open3d's occupancy (majority of 5 random-direction
    # rays per point) on the voxel centres of a coarser grid.
    coarse = grid_for_bounds(bunny.bounds, 64, 2)
    reference = open3d_occupancy(bunny, centres(coarse), nsamples=5).reshape(coarse.shape)
    ours = voxelize_on_grid(bunny, coarse)
    assert (ours == reference).mean() >= 0.995
    assert volume.sum() * grid.pitch**3 == pytest.approx(reference.sum() * coarse.pitch**3, rel=0.02)


def test_unmerged_spot_voxelizes_like_the_merged_mesh():
    spot = load("spot.obj")
    merged = spot.copy()
    merged.merge_vertices(merge_tex=True, merge_norm=True)
    assert not spot.is_watertight and merged.is_watertight
    volume, grid = voxelize(spot, resolution=96)
    assert np.array_equal(voxelize_on_grid(merged, grid), volume)
    assert n_components(volume) == 1 and is_closed(volume)
    assert volume.sum() * grid.pitch**3 == pytest.approx(merged.volume, rel=0.01)


def test_marching_cubes_surface_voxelizes_back_to_its_volume():
    # The surface at level 0.5 separates every voxel centre from those of the
    # other side, so re-voxelizing it on the same grid must give the volume back.
    volume, grid = voxelize(load("stanford-bunny.obj"), resolution=64, padding=2)
    vertices, faces, _, _ = marching_cubes(volume.astype(np.float32), 0.5)
    surface = trimesh.Trimesh(grid.to_world(vertices), faces, process=False)
    assert np.array_equal(voxelize_on_grid(surface, grid), volume)


def test_rocker_arm_keeps_its_through_hole():
    rocker = load("rocker-arm.obj")
    volume, grid = voxelize(rocker, resolution=96)
    assert n_components(volume) == 1 and is_closed(volume)
    # Euler characteristic = components - tunnels + cavities = 1 - 1 + 0.
    assert euler_number(volume, connectivity=3) == 0
    assert euler_number(volume, connectivity=1) == 0
    assert volume.sum() * grid.pitch**3 == pytest.approx(rocker.volume, rel=0.01)


# ------------------------------------------------------------------------------- a voxel mesh's own lattice


def _voxel_mesh(name="fandisk", resolution=64, seed=1):
    from skelfilter.mesh import pipeline as mesh_pipeline

    return mesh_pipeline.noisy_mesh(load(f"{name}.obj"), resolution=resolution, seed=seed)


@pytest.mark.parametrize("name", ["fandisk", "spot"])
def test_a_voxel_mesh_gives_back_its_voxels_on_its_own_lattice(name, tmp_path):
    from skelfilter.io import mesh_files
    from skelfilter.mesh.voxelize import grid_on_lattice, voxel_lattice

    noisy, masks, grid = _voxel_mesh(name)
    mesh_files.save_mesh(noisy, tmp_path / "noisy.obj")  # through a text file: digits are lost
    noisy = mesh_files.load_mesh(tmp_path / "noisy.obj")
    pitch, anchor = voxel_lattice(noisy)
    assert pitch == pytest.approx(grid.pitch, rel=1e-5)
    offset = (anchor - grid.origin) / grid.pitch
    assert np.allclose(offset, np.round(offset), atol=1e-3)
    lattice = grid_on_lattice(noisy.bounds, pitch, anchor, padding=3)
    occupancy = voxelize_on_grid(noisy, lattice)
    shift = np.round((lattice.origin - grid.origin) / grid.pitch).astype(int)
    back = np.zeros_like(masks.noisy)
    back[tuple((np.argwhere(occupancy) + shift).T)] = True
    assert np.array_equal(back, masks.noisy)
    assert has_border_margin(occupancy, 3)


def test_meshes_off_any_lattice_have_none():
    from skelfilter.mesh.voxelize import voxel_lattice

    for name in ("fandisk.obj", "spot.obj", "stanford-bunny.obj"):
        assert voxel_lattice(load(name)) is None
    noisy = _voxel_mesh()[0]
    rotated = noisy.copy().apply_transform(trimesh.transformations.rotation_matrix(0.3, [1, 2, 3]))
    assert voxel_lattice(rotated) is None
    assert voxel_lattice(trimesh.smoothing.filter_taubin(noisy.copy(), iterations=3)) is None
    # A regular tessellation has every vertex on planes: no coordinate between two of them.
    assert voxel_lattice(trimesh.creation.box().subdivide().subdivide().subdivide()) is None


def test_the_automatic_grid_of_a_voxel_mesh_is_its_own():
    from skelfilter.mesh import pipeline as mesh_pipeline
    from skelfilter.runtime.progress import Progress

    noisy, masks, grid = _voxel_mesh(resolution=100)
    progress = Progress(enabled=False)
    _, result, used = mesh_pipeline.denoise_mesh_detailed(noisy, progress=progress)
    assert any("the voxel grid its surface was made on" in n for n in progress.notes)
    assert used.pitch == pytest.approx(grid.pitch, rel=1e-5)
    offset = (used.origin - grid.origin) / grid.pitch
    assert np.allclose(offset, np.round(offset), atol=1e-3)
