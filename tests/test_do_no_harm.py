"""Do no harm: clean shapes with thin parts and real models people make pass through the default
unchanged, thin parts survive the noise's removal, and every flag either takes effect or is refused with
a reason."""

import importlib.util
import os

import manifold3d
import numpy as np
import pytest
import trimesh
from scipy import ndimage

from skelfilter.core import pipeline
from skelfilter.core.decision import stage_pruning
from skelfilter.core.synthetic_noise import add_noise
from skelfilter.errors import ParameterError
from skelfilter.evaluation import metrics
from skelfilter.io import mesh_files
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.mesh.voxelize import voxelize
from skelfilter.params import DenoiseParams
from skelfilter.runtime.progress import Progress


def _mesh(solid):
    m = solid.to_mesh()
    return trimesh.Trimesh(np.asarray(m.vert_properties)[:, :3], np.asarray(m.tri_verts), process=True)


def _box(size, centre):
    return manifold3d.Manifold.cube(size, True).translate(centre)


DATA = os.path.join(os.path.dirname(__file__), "data")
# PyVista's example meshes, shipped in tests/data (tests/data/README.md), and MeshLab's sample meshes
# from the installed pymeshlab (GPL: read where they are, not copied; `make test` installs it, and a
# missing one fails here rather than skipping the models).
MESHLAB_SAMPLES = os.path.join(os.path.dirname(importlib.util.find_spec("pymeshlab").origin), "tests",
                               "sample_meshes")
REAL_MODELS = ([os.path.join(DATA, name) for name in ("ant.ply", "airplane.ply", "nut.ply", "sphere.ply")]
               + [os.path.join(MESHLAB_SAMPLES, name)
                  for name in ("cow.obj", "cube.obj", "airplane.obj", "bunny10k_textured.obj", "bone.ply")])


@pytest.mark.parametrize("path", REAL_MODELS, ids=os.path.basename)
def test_a_real_clean_model_comes_back_unchanged(path):
    # A low-poly model's faces turn sharply from one to the next (the ant's legs have six sides), as
    # noise turns them; its vertices move alike where noise moves them apart. The ant read 7.9° and
    # was smoothed (every vertex moved, up to 7 % of the diagonal); MeshLab's cow, 5.4°, 3 %.
    mesh = mesh_files.load_mesh(path)
    out = mesh_pipeline.denoise_mesh(mesh, DenoiseParams(), Progress(enabled=False))
    diagonal = float(np.linalg.norm(np.ptp(np.asarray(mesh.vertices), axis=0)))
    assert len(out.vertices) == len(mesh.vertices) and np.array_equal(out.faces, mesh.faces)
    assert np.abs(np.asarray(out.vertices) - np.asarray(mesh.vertices)).max() <= 0.001 * diagonal


@pytest.fixture(scope="module")
def winged():
    """A body 1 long with two wings 0.025 thick (4 voxels at 160) and a fin 0.0156 thick (2.5 voxels)."""
    body = _box((1.0, 0.12, 0.12), (0, 0, 0))
    wings = _box((0.25, 0.9, 0.025), (0, 0, 0))
    fin = _box((0.15, 0.0156, 0.18), (0.4, 0, 0.12))
    return _mesh(manifold3d.Manifold.batch_boolean([body, wings, fin], manifold3d.OpType.Add))


@pytest.fixture(scope="module")
def legged():
    """A body on four legs 0.04 square (6.4 voxels at 160), 0.35 long."""
    body = _box((0.8, 0.3, 0.25), (0, 0, 0.3))
    legs = [_box((0.04, 0.04, 0.35), (x, y, 0.0)) for x in (-0.3, 0.3) for y in (-0.1, 0.1)]
    return _mesh(manifold3d.Manifold.batch_boolean([body] + legs, manifold3d.OpType.Add))


@pytest.mark.parametrize("name", ["winged", "legged"])
def test_a_clean_thin_shape_comes_back_unchanged(request, name):
    mesh = request.getfixturevalue(name)
    progress = Progress(enabled=False)
    out = mesh_pipeline.denoise_mesh(mesh, DenoiseParams(resolution=160), progress)
    assert np.array_equal(out.faces, mesh.faces) and np.array_equal(out.vertices, mesh.vertices)
    assert any("clean under" in n for n in progress.notes)  # decided by the roughness, nothing voxelized
    # the voxel stage, asked for, finds no noise either
    progress = Progress(enabled=False)
    out, result, _ = mesh_pipeline.denoise_mesh_detailed(mesh, DenoiseParams(resolution=160, output_mesh="input"),
                                                         progress)
    assert result.voxels_changed == 0 and not result.noise["foreground"].found
    assert any("none found" in n for n in progress.notes)
    # the pruning alone (the previous default) takes the thin parts: this is what keep_features prevents
    occupancy = voxelize(mesh, 160, 40)[0]
    pruned = pipeline.denoise_volume(occupancy, keep_features="off", prune="as-told").mask
    assert np.count_nonzero(occupancy & ~pruned) > 0.01 * np.count_nonzero(occupancy)


def test_thin_parts_stay_while_the_noise_goes(legged):
    clean = voxelize(legged, 160, 20)[0]
    noise = add_noise(clean, p=0.003, r=2.1, h=3, l=6, seed=1)
    result = pipeline.denoise_volume(noise.noisy)
    thin = metrics.thin_parts(clean)
    legs = clean.copy()
    legs[:, :, int(np.flatnonzero(clean.any(axis=(0, 1)))[0]) + 40:] = False  # the legs' lower half
    estimate = result.noise["foreground"]
    # bumps stand h + r = 5.1 above the clean surface; the 99 % quantile of the peaks above the pruned shape
    # (lower by a voxel or two, and where stripes stack) measured 10.9
    assert estimate.found and 5.0 <= estimate.height <= 11.5
    assert np.count_nonzero(legs & result.mask) / np.count_nonzero(legs) > 0.99
    assert metrics.thin_parts_kept(result.mask, thin) > 0.9
    left = np.count_nonzero(noise.bumps & result.mask) / np.count_nonzero(noise.bumps)
    assert left < 0.5  # measured 0.31: the noise on the legs comes back with them
    assert ndimage.label(result.mask, structure=np.ones((3, 3, 3)))[1] == 1


def test_thin_parts_against_a_brute_force_opening():
    rng = np.random.default_rng(2)
    shape = ndimage.binary_closing(rng.random((30, 30, 30)) < 0.5, iterations=3)
    ball = np.add.outer(np.add.outer(np.arange(-4, 5) ** 2, np.arange(-4, 5) ** 2), np.arange(-4, 5) ** 2) <= 16
    want = shape & ~ndimage.binary_opening(shape, structure=ball)
    assert np.array_equal(metrics.thin_parts(shape, 4.0), want)


def test_voxel_flags_on_an_open_surface_are_refused():
    sheet = trimesh.creation.box((1.0, 1.0, 0.2))
    sheet.update_faces(sheet.face_normals[:, 2] < 0.5)  # no top: an open surface
    sheet.remove_unreferenced_vertices()
    with pytest.raises(ParameterError, match="threshold would have no effect"):
        mesh_pipeline.denoise_mesh(sheet, threshold=12)
    mesh_pipeline.denoise_mesh(sheet, resolution=64)  # the resolution decides what a solid is: no refusal


def test_a_given_threshold_runs_the_voxel_stage_on_a_fine_noise_mesh():
    rng = np.random.default_rng(0)
    box = trimesh.creation.box((1.0, 1.0, 1.0)).subdivide().subdivide().subdivide()
    noisy = trimesh.Trimesh(box.vertices + rng.normal(0, 0.03, box.vertices.shape), box.faces)
    progress = Progress(enabled=False)
    mesh_pipeline.denoise_mesh_detailed(noisy, DenoiseParams(threshold=10, resolution=64), progress)
    assert "foreground/importance" in progress.timings  # the voxel stage ran
    progress = Progress(enabled=False)
    mesh_pipeline.denoise_mesh_detailed(noisy, DenoiseParams(resolution=64), progress)
    assert "foreground/importance" not in progress.timings  # left to itself it skips it (fine noise)


def test_the_default_threshold_given_in_voxels_is_the_default():
    # t = 0.1875 of 64 voxels is 12: given as 12 voxels it is the default's, and changes nothing
    rng = np.random.default_rng(0)
    box = trimesh.creation.box((1.0, 1.0, 1.0)).subdivide().subdivide().subdivide()
    noisy = trimesh.Trimesh(box.vertices + rng.normal(0, 0.03, box.vertices.shape), box.faces)
    given, _, _ = mesh_pipeline.denoise_mesh_detailed(noisy, DenoiseParams(threshold=12, resolution=64))
    left, _, _ = mesh_pipeline.denoise_mesh_detailed(noisy, DenoiseParams(resolution=64))
    assert np.array_equal(given.vertices, left.vertices) and given.metadata == left.metadata
    clean = trimesh.creation.icosphere(3)
    for params in (DenoiseParams(resolution=160, threshold=30), DenoiseParams(threshold_relative=0.1875)):
        assert not params.threshold_given and not params.prunes_as_told
        assert mesh_pipeline.denoise_mesh(clean, params).metadata["skelfilter"]["route"] == "as it was"
    assert DenoiseParams(resolution=160, threshold=29).threshold_given


def test_pruning_is_a_choice_of_its_own_not_implied_by_other_parameters():
    for given in ({"threshold": 20}, {"noise_height": 5.0}, {"keep_features": "off"}, {"prune": "measured"}):
        assert not DenoiseParams(**given).prunes_as_told
    assert DenoiseParams(prune="as-told").prunes_as_told and DenoiseParams(preset="thesis").prunes_as_told
    # a clean cube: measured, whatever the threshold, noise height or features, it passes through
    cube = np.zeros((40, 40, 40), dtype=bool)
    cube[8:32, 8:32, 8:32] = True
    for given in ({}, {"threshold": 4.0}, {"noise_height": 1.0}, {"keep_features": "off"}):
        result = pipeline.denoise_volume(cube, **given)
        assert np.array_equal(result.mask, cube) and not result.noise["foreground"].found, given
    # as told, the pruning rounds the cube's edges
    assert not np.array_equal(pipeline.denoise_volume(cube, prune="as-told", keep_features="off").mask, cube)


def test_the_new_mesh_warns_when_it_drops_colours(legged):
    noise = add_noise(voxelize(legged, 128, 20)[0], p=0.006, r=2.1, h=3, l=6, seed=2)
    from skelfilter.mesh import marching_cubes
    from skelfilter.mesh.voxelize import grid_for_bounds
    noisy = marching_cubes.mask_to_mesh(noise.noisy, grid_for_bounds(legged.bounds, 128, 20))
    noisy.visual.vertex_colors = np.tile([200, 30, 30, 255], (len(noisy.vertices), 1)).astype(np.uint8)
    with pytest.warns(UserWarning, match="no vertex colours"):
        mesh_pipeline.denoise_mesh(noisy, resolution=128, noise_height=8.0)


def _gear():
    """A spur gear 1 across and 0.16 thick with 24 teeth 0.07 high and 4 voxels wide at the tip (at
    160), a bore and six lightening holes (the quality benchmark's gear)."""
    tooth = manifold3d.CrossSection([[(0.43, -0.035), (0.5, -0.0125), (0.5, 0.0125), (0.43, 0.035)]])
    outline = manifold3d.CrossSection.circle(0.44, 192)
    for angle in np.linspace(0.0, 360.0, 24, endpoint=False):
        outline = outline + tooth.rotate(float(angle))
    holes = manifold3d.CrossSection.circle(0.1, 96)
    for a in np.radians(np.arange(0, 360, 60)):
        holes = holes + manifold3d.CrossSection.circle(0.06, 96).translate((0.28 * np.cos(a), 0.28 * np.sin(a)))
    return _mesh((outline - holes).extrude(0.16))


@pytest.mark.parametrize("resolution", [160, 192])
def test_a_clean_gear_as_a_volume_passes_through(resolution):
    # Each tooth's tip is a ridge the pruning shaves; its corners stand half a voxel above the ridge.
    # Counted as peaks of their own (5-cube maxima), the corners of the 24 teeth covered 9-10 % of
    # the surface cells at 192 voxels, and the teeth were cut as noise.
    occupancy = voxelize(_gear(), resolution, 6)[0]
    progress = Progress(enabled=False)
    result = pipeline.denoise_volume(occupancy, progress=progress)
    assert result.voxels_changed == 0
    assert not result.noise["foreground"].found and result.noise["foreground"].coverage < 0.04


@pytest.fixture(scope="module")
def chair_160():
    """The quality benchmark's chair (seat 5 voxels thick, legs 6 voxels square) at 160 voxels."""
    from benchmarks import shapes
    return voxelize(shapes.chair(), 160, 20)[0]


def test_sparse_bumps_on_a_chair_are_measured_at_a_finer_pruning(chair_160, monkeypatch):
    # The pruning at t keeps a few percent of the chair (the seat's core): every leg and slat stands higher
    # than noise above it, and with only the coarse pruning the noisy chair passed through whole.
    noise = add_noise(chair_160, p=0.003, r=2.1, h=3, l=6, seed=1)
    thin = metrics.thin_parts(chair_160)
    progress = Progress(enabled=False)
    result = pipeline.denoise_volume(noise.noisy, progress=progress)
    assert any("pruned again at t / 2" in n for n in progress.notes)
    assert result.noise["foreground"].found
    left = np.count_nonzero(noise.bumps & result.mask) / np.count_nonzero(noise.bumps)
    assert left < 0.35  # measured 0.23
    assert metrics.thin_parts_kept(result.mask, thin) > 0.98
    assert np.count_nonzero(chair_160 & ~result.mask) < 0.01 * np.count_nonzero(chair_160)
    monkeypatch.setattr(stage_pruning, "FINER_THRESHOLDS", ())
    assert pipeline.denoise_volume(noise.noisy).voxels_changed == 0


def test_a_clean_chair_passes_through_the_finer_prunings(chair_160):
    progress = Progress(enabled=False)
    result = pipeline.denoise_volume(chair_160, progress=progress)
    assert any("pruned again at t / 2" in n for n in progress.notes)
    assert result.voxels_changed == 0 and not result.noise["foreground"].found


def test_high_bumps_on_a_chair_keep_the_fine_pass_where_the_input_shows_no_noise(chair_160):
    # Bumps 7 voxels high on legs 6 thick: on the input the pruning takes the legs whole with their
    # noise and finds nothing, at every threshold; after the fine pass it finds the noise. The result
    # after the fine pass is kept rather than the noisy input passed through.
    noise = add_noise(chair_160, p=0.01, r=2.1, h=7, l=4, seed=1)
    progress = Progress(enabled=False)
    result = pipeline.denoise_volume(noise.noisy, progress=progress)
    assert any("the result after the fine pass is kept" in n for n in progress.notes)
    error = np.count_nonzero(result.mask ^ chair_160) / np.count_nonzero(noise.noisy ^ chair_160)
    assert error < 0.5  # measured 0.33
    assert metrics.thin_parts_kept(result.mask, metrics.thin_parts(chair_160)) > 0.9  # measured 0.96
