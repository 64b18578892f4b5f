import math
import os

import numpy as np
import pytest
import trimesh

from skelfilter.core.synthetic_noise import add_noise
from skelfilter.errors import InputError, ParameterError
from skelfilter.evaluation import metrics
from skelfilter.io import mesh_files
from skelfilter.mesh.marching_cubes import mask_to_mesh
from skelfilter.mesh.voxelize import Grid

N = 20_000  # surface samples: enough for ~1% on the analytic values, quick
PITCH = 0.05
# Voxel centres at 0.025 + k * 0.05: no centre lies on a face of the unit boxes below.
GRID = Grid(np.full(3, -0.475), PITCH, (46, 46, 46))


def unit_cube():
    return trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])


# ---- thesis measures -------------------------------------------------------


def test_skeleton_errors_on_hand_built_sets():
    s = np.array([0, 1, 2, 3])
    sv = np.array([5, 4, 3, 2, 2])  # unsorted, repeated: a set all the same
    assert metrics.skeleton_error(sv, s) == pytest.approx(1 - 2 / 6)  # eq. 4.17
    assert metrics.skeleton_false_positive_rate(sv, s) == pytest.approx(2 / 4)  # eq. 4.18
    assert metrics.skeleton_error(s, s) == 0 and metrics.skeleton_false_positive_rate(s, s) == 0
    # Boolean volumes give the same answers as flat indices (C order).
    vs, vsv = np.zeros((2, 2, 2), bool), np.zeros((2, 2, 2), bool)
    vs.reshape(-1)[s] = True
    vsv.reshape(-1)[sv] = True
    assert metrics.skeleton_error(vsv, s) == pytest.approx(2 / 3)
    assert metrics.skeleton_false_positive_rate(vsv, vs) == pytest.approx(0.5)
    assert math.isnan(metrics.skeleton_error([], []))
    assert math.isnan(metrics.skeleton_false_positive_rate(np.array([], np.int64), s))
    with pytest.raises(ParameterError):
        metrics.skeleton_error(np.array([0.5]), s)


def test_reconstruction_error_uses_the_union_with_the_reconstruction():
    x = np.zeros((4, 4, 4), bool)
    x[:2] = True  # 32 voxels
    r = np.zeros_like(x)
    r[1:3] = True  # 32 voxels, 16 shared
    assert metrics.reconstruction_error(r, x) == pytest.approx(1 - 16 / 48)  # eq. 6.5, corrected
    assert metrics.reconstruction_error(x, x) == 0


def test_geodesic_errors_eq_7_23_7_24():
    eps, m = metrics.geodesic_errors([1.0, 2.0, 4.0], [1.1, 2.0, 2.0])  # relative errors 0.1, 0, 0.5
    assert eps == pytest.approx(0.2) and m == pytest.approx(0.5)
    assert metrics.geodesic_errors([3.0], [3.0]) == (0.0, 0.0)
    assert all(math.isnan(v) for v in metrics.geodesic_errors([], []))
    with pytest.raises(ParameterError):
        metrics.geodesic_errors([1.0, 0.0], [1.0, 1.0])
    with pytest.raises(ParameterError):
        metrics.geodesic_errors([1.0, 2.0], [1.0])


# ---- surface distances -----------------------------------------------------


def test_chamfer_and_hausdorff_of_a_translated_cube():
    a = unit_cube()
    b = a.copy()
    b.apply_translation([0.1, 0, 0])
    # Mean distance from A's surface to B's: face x=0 -> 0.1; face x=1 (inside B) ->
    # E[min(0.1, distance to the square's border)] = (1 - 0.8^3) / 6; four side faces
    # -> 0.1^2 / 2 each; over the six unit faces. Symmetric, so Chamfer is the same.
    directed = (0.1 + (1 - 0.8**3) / 6 + 4 * 0.005) / 6
    assert metrics.chamfer_distance(a, b, GRID, n_samples=N) == pytest.approx(directed / PITCH, rel=0.03)
    # 27% of each surface is exactly 0.1 away: both the 95th percentile and the max are 0.1.
    h95, hmax = metrics.hausdorff_distance(a, b, GRID, n_samples=N)
    assert h95 == pytest.approx(0.1 / PITCH, abs=1e-6) and hmax == pytest.approx(0.1 / PITCH, abs=1e-6)


def test_distances_of_a_mesh_to_itself_are_zero():
    a = unit_cube()
    # the samples lie on the surface up to their own rounding
    assert metrics.chamfer_distance(a, a, GRID, n_samples=N) < 1e-5
    assert metrics.hausdorff_distance(a, a, GRID, n_samples=N)[1] < 1e-5
    sphere = trimesh.creation.icosphere(3)
    assert metrics.chamfer_distance(sphere, sphere, GRID, n_samples=N) < 1e-3
    assert metrics.hausdorff_distance(sphere, sphere, GRID, n_samples=N)[1] < 0.1


def test_normal_error_zero_for_identical_and_known_for_rotated():
    a = unit_cube()
    assert metrics.normal_error(a, a) == pytest.approx(0, abs=1e-6)
    r = a.copy()
    r.apply_transform(trimesh.transformations.rotation_matrix(np.radians(10), [0, 0, 1], [0.5, 0.5, 0.5]))
    # The four side faces turn by 10 degrees, top and bottom not: 4 * 10 / 6 on equal areas.
    assert metrics.normal_error(r, a) == pytest.approx(40 / 6, abs=1e-6)


SOTA = os.path.join(os.path.dirname(__file__), "..", "benchmarks", "data", "sota")


@pytest.mark.parametrize("pair, noisy, published", [("gcn-trimstar-n3", (28.82, 0.306), (5.32, 0.082)),
                                                   ("tgv-block", (22.64, 0.214), (2.85, 0.069))])
def test_literature_scores_match_the_authors_figures(pair, noisy, published):
    """θ and E_v as the field's released code computes them, on the two pairs whose authors published
    their scores (benchmarks/data/README.md)."""
    clean = mesh_files.load_mesh(os.path.join(SOTA, pair, "clean.obj"))
    for name, (theta, e_v) in (("noisy", noisy), ("published", published)):
        scores = metrics.literature_errors(mesh_files.load_mesh(os.path.join(SOTA, pair, f"{name}.obj")), clean)
        assert scores.theta == pytest.approx(theta, abs=0.005) and scores.e_v == pytest.approx(e_v, abs=0.0005)


def test_literature_theta_is_index_matched_and_unweighted_else_nearest():
    clean = trimesh.creation.icosphere(2)
    tilted = clean.copy()
    tilted.vertices[clean.faces[0]] += 0.05 * clean.face_normals[0] + [0.03, 0.0, 0.0]
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", tilted.face_normals, clean.face_normals), -1, 1)))
    assert metrics.literature_normal_error(tilted, clean) == pytest.approx(angle.mean())  # plain mean, same index
    shuffled = trimesh.Trimesh(tilted.vertices, tilted.faces[::-1], process=False)  # other faces: the nearest
    assert metrics.literature_normal_error(shuffled, clean) == pytest.approx(angle.mean(), rel=1e-6)


def test_sharp_edge_error_zero_for_the_cube_positive_when_smoothed():
    a = unit_cube()
    mean, mx, n = metrics.sharp_edge_error(a, a, GRID)
    assert n == 12 and mean < 1e-5 and mx < 1e-5
    smooth = a.subdivide().subdivide().subdivide().subdivide()
    trimesh.smoothing.filter_laplacian(smooth, iterations=10)
    mean, mx, _ = metrics.sharp_edge_error(smooth, a, GRID)
    assert mean > 0.1 and mx > mean  # corners and edges rounded by more than a tenth of a voxel
    flat = trimesh.creation.icosphere(3)
    assert metrics.sharp_edge_error(flat, flat, GRID)[2] == 0  # no edge above 30 degrees


# ---- volumes, noise, topology ----------------------------------------------


def test_iou_of_a_box_and_its_half():
    half = trimesh.creation.box(bounds=[[0, 0, 0], [0.5, 1, 1]])
    assert metrics.volumetric_iou(half, unit_cube(), GRID) == pytest.approx(0.5)
    assert metrics.volumetric_iou(unit_cube(), unit_cube(), GRID) == 1.0


@pytest.fixture(scope="module")
def noisy_box():
    x = np.zeros((60, 60, 60), bool)
    x[15:45, 15:45, 15:45] = True
    noise = add_noise(x, dents=True, seed=1)
    grid = Grid(np.zeros(3), 1.0, x.shape)
    return noise, grid, mask_to_mesh(x, grid), mask_to_mesh(noise.noisy, grid)


def test_noise_removed_and_shrinkage(noisy_box):
    noise, grid, clean, noisy = noisy_box
    assert noise.bumps.any() and noise.dents.any()
    assert metrics.noise_removed(clean, noise, grid) == {
        "noise_removed": 1.0, "bumps_removed": 1.0, "dents_removed": 1.0}
    kept = metrics.noise_removed(noisy, noise, grid)
    assert kept["noise_removed"] < 0.05 and kept["bumps_removed"] < 0.05 and kept["dents_removed"] < 0.05
    assert metrics.shrinkage(clean, clean, grid, noise) == 0.0
    assert metrics.shrinkage(noisy, clean, grid, noise) == 0.0  # noise leaves the far volume alone
    # A result missing the top half loses about half the volume far from the noise.
    s = metrics.shrinkage(trimesh.creation.box(bounds=[[14.5] * 3, [44.5, 44.5, 29.5]]), clean, grid, noise)
    assert 0.3 < s < 0.7
    assert metrics.shrinkage(clean, clean, grid) == 0.0


def test_edge_manifold_and_watertight_flags():
    box = unit_cube()
    assert box.is_watertight and metrics.is_edge_manifold(box)
    open_box = trimesh.Trimesh(box.vertices, box.faces[1:], process=False)
    assert not open_box.is_watertight and metrics.is_edge_manifold(open_box)
    # Three triangles on one edge: not edge-manifold.
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], float)
    tri = trimesh.Trimesh(v, [[0, 1, 2], [1, 0, 3], [0, 1, 4]], process=False)
    assert not metrics.is_edge_manifold(tri)
    m = metrics.mesh_metrics(open_box, box, GRID, n_samples=N)
    assert m["watertight"] is False and m["edge_manifold"] is True and m["faces"] == 11


def test_mesh_metrics_of_the_clean_and_the_noisy_mesh(noisy_box):
    noise, grid, clean, noisy = noisy_box
    same = metrics.mesh_metrics(clean, clean, grid, noise=noise, n_samples=N)
    assert same["chamfer"] < 1e-4 and same["hausdorff_95"] < 1e-4 and same["hausdorff_max"] < 1e-4
    assert same["normal_error_deg"] < 1e-3 and same["theta_deg"] < 1e-3
    assert same["iou"] == 1.0 and same["shrinkage"] == 0.0
    assert same["noise_removed"] == 1.0 and same["sharp_edges"] > 0 and same["sharp_edge_max"] < 1e-6
    assert same["watertight"] and same["edge_manifold"] and same["faces"] == len(clean.faces)
    worse = metrics.mesh_metrics(noisy, clean, grid, noise=noise, n_samples=N)
    assert worse["chamfer"] > 0.5 and worse["hausdorff_max"] > 3 and worse["iou"] < 1
    assert worse["noise_removed"] < 0.05 and worse["sharp_edge_mean"] > 0
    assert "noise_removed" not in metrics.mesh_metrics(clean, clean, grid, n_samples=N)


def test_nan_and_empty_results_give_an_error_entry():
    box = unit_cube()
    nan = box.copy()
    nan.vertices[0] = np.nan
    out = metrics.mesh_metrics(nan, box, GRID)
    assert "non-finite" in out["error"] and out["faces"] == 12
    out = metrics.mesh_metrics(trimesh.Trimesh(), box, GRID)
    assert "no faces" in out["error"] and out["faces"] == 0
    flat = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2]], process=False)
    assert "area" in metrics.mesh_metrics(flat, box, GRID)["error"]
    with pytest.raises(InputError):
        metrics.mesh_metrics(box, trimesh.Trimesh(), GRID)


def test_thickness_under_tells_a_bump_on_a_body_from_one_on_a_plate():
    from skelfilter.evaluation.metrics import thickness_under

    clean = np.zeros((40, 40, 40), dtype=bool)
    clean[5:18, 5:35, 5:35] = True  # a body 13 voxels thick
    clean[18:30, 28:30, 5:35] = True  # a plate 2 voxels thick standing on it
    bumps = np.zeros_like(clean)
    bumps[18:20, 14:16, 18:20] = True  # on the body's face, away from its edges and the plate
    bumps[22:24, 30:32, 18:20] = True  # on the plate's side
    thick = thickness_under(bumps, clean, 12)
    assert thick[18:20, 14:16, 18:20].all() and not thick[22:24, 30:32, 18:20].any()
    assert not (thick & ~bumps).any()
    # a slab of 13 voxels is thicker than 12, not than 14
    assert not thickness_under(bumps, clean, 14)[18:20, 14:16, 18:20].any()


def test_concavities_against_the_hull_tested_voxel_by_voxel():
    from scipy import ndimage, spatial

    from skelfilter.evaluation.metrics import concavities, concavity_filled

    cup = np.zeros((24, 24, 24), dtype=bool)
    cup[3:20, 3:20, 3:20] = True
    cup[7:16, 7:16, 7:20] = False  # open at the top: a cavity
    cup[10:12, 3:5, 3:20] = False  # and a groove on a side
    for depth in (0.0, 2.0):
        points = np.argwhere(cup)
        equations = spatial.ConvexHull(points).equations
        grid = np.indices(cup.shape).reshape(3, -1).T
        in_hull = (grid @ equations[:, :3].T + equations[:, 3] <= 1e-9).all(axis=1).reshape(cup.shape)
        want = in_hull & ~cup & (ndimage.distance_transform_edt(~cup) > depth)
        got = concavities(cup, depth)
        assert np.array_equal(got, want) and got[11, 11, 15]
    filled = cup.copy()
    filled[7:16, 7:16, 7:10] = True
    assert 0 < concavity_filled(filled, got) < 1 and concavity_filled(cup, got) == 0
    assert np.isnan(concavity_filled(cup, np.zeros_like(cup)))
