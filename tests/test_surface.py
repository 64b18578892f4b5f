"""The surface made from voxels (`surface_field.smooth_constrained`, `marching_cubes.mask_to_world_mesh`):
it encloses exactly its voxels, is sound, and is the smooth surface the voxels sample; clean label maps
pass through whatever their spacing (benchmarks/surfaces.py measures the rest against 3D Slicer's export
and VTK's surface nets)."""

import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from skelfilter.core import pipeline, volume_fine_pass
from skelfilter.core.spacing import signed_distance
from skelfilter.core.surface_field import smooth_constrained
from skelfilter.mesh.marching_cubes import mask_to_world_mesh

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
import surfaces  # noqa: E402


def _blob(shape, seed):
    from scipy import ndimage

    return ndimage.gaussian_filter(np.random.default_rng(seed).standard_normal(shape), 2.0) > 0.05


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("spacing", [(1.0, 1.0, 1.0), (0.7, 0.7, 2.1)])
def test_the_smoothed_field_keeps_every_voxel_centre_on_its_side(seed, spacing):
    mask = _blob((20, 22, 18), seed)
    field = smooth_constrained(signed_distance(mask, spacing), mask, unit=min(spacing))
    assert ((field > 0) == mask).all()


def test_fixed_voxels_keep_their_values():
    mask = _blob((20, 20, 20), 3)
    field = signed_distance(mask, (1.0, 1.0, 1.0))
    fixed = np.zeros(mask.shape, dtype=bool)
    fixed[:, :10] = True
    out = smooth_constrained(field, mask, fixed)
    assert np.array_equal(out[fixed], field[fixed]) and not np.array_equal(out[~fixed], field[~fixed])


@pytest.mark.parametrize("seed", [0, 4])
def test_the_mesh_encloses_exactly_the_voxel_centres_in_world_coordinates(seed):
    mask = _blob((18, 20, 16), seed)
    affine = np.array([[0, 0, 2.0, 5.0], [0.8, 0, 0, -3.0], [0, -0.8, 0, 1.0], [0, 0, 0, 1]])
    mesh = mask_to_world_mesh(mask, affine)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    assert np.count_nonzero(mesh.area_faces <= 1e-12) == 0
    ijk = np.indices(mask.shape).reshape(3, -1).T
    centres = ijk @ affine[:3, :3].T + affine[:3, 3]
    assert np.array_equal(surfaces._inside(mesh, centres), mask.reshape(-1))


@pytest.mark.parametrize("spacing", ["iso", "thick"])
def test_a_ball_s_label_map_comes_out_smooth_and_true(spacing):
    """Against the analytic ball (radius 11 mm): the staircase's normal error is 21-24 degrees; the
    smooth surface's 4.2 and 5.5, 3D Slicer's export 4.5 and 6.1 (benchmarks/surfaces.py)."""
    solid = surfaces.SOLIDS["ball"]()
    mask, affine = surfaces.label_map(solid, surfaces.SPACINGS[spacing], 1)
    truth = surfaces.true_surface_samples(solid, 5000)
    smooth = surfaces.score(mask_to_world_mesh(mask, affine), solid, truth)
    plain = surfaces.score(mask_to_world_mesh(mask, affine, smooth=False), solid, truth)
    assert plain["normal_error"] > 18 and smooth["normal_error"] < 6.0
    assert smooth["distance"] < 0.11 and abs(smooth["volume_error"]) < 2.5
    assert smooth["manifold"] and smooth["pieces"] == 1 and smooth["zero_area"] == 0


@pytest.mark.parametrize("solid, spacing", [("torus", "thick"), ("rod", "thick"), ("rod", "thick-x"),
                                            ("bent vessel", "thick-fine"), ("box", "thick-x")])
def test_a_clean_label_map_passes_through_whatever_its_spacing(solid, spacing):
    """Thick slices and thin parts are sampling, not noise: 0 voxels changed."""
    mask, affine = surfaces.label_map(surfaces.SOLIDS[solid](), surfaces.SPACINGS[spacing], 1)
    result = pipeline.denoise_volume(mask, spacing=np.diag(affine)[:3])
    assert result.voxels_changed == 0 and np.array_equal(result.mask, mask)


def test_a_thin_rod_s_roughness_is_its_sampling_and_boundary_flips_are_noise():
    mask, _ = surfaces.label_map(surfaces.SOLIDS["rod"](), surfaces.SPACINGS["thick"], 1)
    clean = volume_fine_pass.voxel_roughness(mask, sampled=True)
    assert clean.roughness >= volume_fine_pass.LEAST_ROUGHNESS and not clean.found
    assert "thin parts" in clean.describe()
    assert volume_fine_pass.voxel_roughness(surfaces.boundary_noise(mask, 1), sampled=True).found


@pytest.mark.parametrize("surface", ["smooth", "plain"])
def test_the_surface_flag_takes_effect_on_a_volume_s_mesh(tmp_path, surface):
    """``smooth`` (the default) is `mask_to_world_mesh`'s surface; ``plain`` (the thesis presets') the
    marching cubes of the pipeline's field, the staircase."""
    from skelfilter.jobs.denoise_file import denoise_file
    from skelfilter.params import DenoiseParams

    mask, affine = surfaces.label_map(surfaces.SOLIDS["ball"](), (1.0, 1.0, 1.0), 2)
    np.save(tmp_path / "ball.npy", mask)
    denoise_file(tmp_path / "ball.npy", tmp_path / "ball.ply", DenoiseParams(surface=surface))
    written = trimesh.load(tmp_path / "ball.ply", process=False)
    smooth = mask_to_world_mesh(mask, np.eye(4))
    same = len(written.vertices) == len(smooth.vertices) and np.allclose(
        np.sort(written.vertices, axis=0), np.sort(smooth.vertices, axis=0), atol=1e-6)
    assert same == (surface == "smooth")
    written.apply_transform(affine)  # the .npy has no affine: unit voxels from the origin
    normal_error = surfaces.score(written, surfaces.SOLIDS["ball"](),
                                  surfaces.true_surface_samples(surfaces.SOLIDS["ball"](), 3000))["normal_error"]
    assert (normal_error < 6) == (surface == "smooth")


@pytest.mark.parametrize("spacing", [(1.0, 1.0, 2.0), (2.0, 1.0, 1.0)])
def test_every_label_s_surface_encloses_its_voxels_and_neighbours_share_their_boundary(spacing):
    from skelfilter.mesh.marching_cubes import labels_to_world_meshes

    labels = np.zeros((36, 36, 28), np.uint8)
    i, j, k = np.indices(labels.shape)
    labels[(i - 13) ** 2 + (j - 18) ** 2 + (k - 14) ** 2 < 90] = 1
    labels[((i - 23) ** 2 + (j - 18) ** 2 + (k - 14) ** 2 < 90) & (labels == 0)] = 2
    labels[((i - 18) ** 2 + (j - 26) ** 2 + (k - 14) ** 2 < 55) & (labels == 0)] = 3
    affine = np.diag([*spacing, 1.0])
    meshes = labels_to_world_meshes(labels, affine)
    ijk = np.indices(labels.shape).reshape(3, -1).T
    centres = ijk @ affine[:3, :3].T
    for label, mesh in meshes.items():
        assert mesh.is_watertight and mesh.is_winding_consistent
        assert np.array_equal(surfaces._inside(mesh, centres), labels.reshape(-1) == label)
    gaps = surfaces.interface_gaps(labels, affine, meshes)
    assert set(gaps) == {(1, 2), (1, 3), (2, 3)}
    assert max(float(g.max()) for g in gaps.values()) < 1e-4
    independent = {label: mask_to_world_mesh(labels == label, affine) for label in meshes}
    assert max(float(g.max()) for g in surfaces.interface_gaps(labels, affine, independent).values()) > 0.5


def _three_labels():
    labels = np.zeros((30, 30, 24), np.uint8)
    i, j, k = np.indices(labels.shape)
    labels[(i - 11) ** 2 + (j - 15) ** 2 + (k - 12) ** 2 < 60] = 1
    labels[((i - 19) ** 2 + (j - 15) ** 2 + (k - 12) ** 2 < 60) & (labels == 0)] = 2
    labels[((i - 15) ** 2 + (j - 23) ** 2 + (k - 12) ** 2 < 45) & (labels == 0)] = 5
    return labels


def test_all_labels_gives_one_named_part_per_label_and_keeps_a_clean_map(tmp_path):
    from skelfilter.jobs.denoise_file import denoise_file
    from skelfilter.params import DenoiseParams, VolumeParams

    labels = _three_labels()
    np.save(tmp_path / "labels.npy", labels)
    summary = denoise_file(tmp_path / "labels.npy", tmp_path / "parts.glb", DenoiseParams(),
                           VolumeParams(all_labels=True))
    scene = trimesh.load(tmp_path / "parts.glb")
    assert sorted(scene.geometry) == ["label_1", "label_2", "label_5"] and summary["voxels_changed"] == 0
    assert all(m.is_watertight for m in scene.geometry.values())
    denoise_file(tmp_path / "labels.npy", tmp_path / "out.npy", DenoiseParams(), VolumeParams(all_labels=True))
    assert np.array_equal(np.load(tmp_path / "out.npy"), labels)


def test_all_labels_refuses_a_mesh_format_without_parts_and_fractional_data(tmp_path):
    from skelfilter.errors import InputError
    from skelfilter.jobs.denoise_file import denoise_file
    from skelfilter.params import DenoiseParams, VolumeParams

    np.save(tmp_path / "labels.npy", _three_labels())
    with pytest.raises(InputError, match="named part needs a obj or glb output"):
        denoise_file(tmp_path / "labels.npy", tmp_path / "parts.ply", DenoiseParams(), VolumeParams(all_labels=True))
    assert not (tmp_path / "parts.ply").exists()
    np.save(tmp_path / "grey.npy", _three_labels() * 0.5)
    with pytest.raises(InputError, match="not a label map"):
        denoise_file(tmp_path / "grey.npy", tmp_path / "out.npy", DenoiseParams(), VolumeParams(all_labels=True))


def test_the_surface_flag_is_refused_for_a_volume_output(tmp_path):
    from skelfilter.errors import ParameterError
    from skelfilter.jobs.denoise_file import denoise_file
    from skelfilter.params import DenoiseParams

    np.save(tmp_path / "labels.npy", _three_labels() == 1)
    with pytest.raises(ParameterError, match="surface.* would have no effect"):
        denoise_file(tmp_path / "labels.npy", tmp_path / "out.npy", DenoiseParams(surface="plain"))
    assert not (tmp_path / "out.npy").exists()
