"""Point clouds in: Poisson solid, denoised like the mesh the points came from; points moved back."""

import numpy as np
import open3d as o3d
import pytest
import trimesh
from scipy.spatial import cKDTree

from skelfilter.errors import InputError
from skelfilter.io import formats, mesh_files, point_files
from skelfilter.io.samples import sample_path
from skelfilter.jobs import denoise_file
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.params import DenoiseParams, NoiseParams

RESOLUTION = 96


@pytest.fixture(scope="module")
def bumpy(tmp_path_factory):
    """Fandisk with the thesis' stripes, its grid, and 60000 points sampled on it (no normals) with an
    'intensity' attribute, in a PLY file."""
    clean = mesh_files.load_mesh(sample_path("fandisk"))
    noisy, _, grid = mesh_pipeline.noisy_mesh(clean, NoiseParams(resolution=RESOLUTION, seed=2))
    points, _ = trimesh.sample.sample_surface_even(noisy, 60000, seed=1)
    cloud = o3d.t.geometry.PointCloud(o3d.core.Tensor(points.astype(np.float32)))
    cloud.point.intensity = o3d.core.Tensor(np.arange(len(points), dtype=np.float32)[:, None])
    path = tmp_path_factory.mktemp("cloud") / "fandisk-points.ply"
    o3d.t.io.write_point_cloud(str(path), cloud)
    return noisy, grid, path


def chamfer(a, b):
    pa, pb = a.sample(50000), b.sample(50000)
    return (cKDTree(pb).query(pa)[0].mean() + cKDTree(pa).query(pb)[0].mean()) / 2


def test_a_cloud_gives_the_mesh_routes_result(bumpy, tmp_path):
    noisy, grid, path = bumpy
    assert formats.input_kind(path) == "points"
    # the route, not the noise decision, is tested
    params = DenoiseParams(resolution=RESOLUTION, keep_features="off", prune="as-told")
    denoise_file.denoise_file(path, tmp_path / "out.ply", params)
    out = mesh_files.load_mesh(tmp_path / "out.ply")
    from_mesh = mesh_pipeline.denoise_mesh(noisy, params.with_(output_mesh="closed"))
    assert out.is_watertight and out.volume > 0
    assert chamfer(out, from_mesh) < grid.pitch  # within a voxel of the mesh route
    assert chamfer(out, from_mesh) < 0.5 * chamfer(noisy, from_mesh)  # and denoised like it


def test_points_moved_onto_the_surface_keep_their_attributes(bumpy, tmp_path):
    _, grid, path = bumpy
    denoise_file.denoise_file(path, tmp_path / "moved.ply", DenoiseParams(resolution=RESOLUTION), points=True)
    denoise_file.denoise_file(path, tmp_path / "mesh.ply", DenoiseParams(resolution=RESOLUTION))
    before, after = o3d.t.io.read_point_cloud(str(path)), o3d.t.io.read_point_cloud(str(tmp_path / "moved.ply"))
    assert np.array_equal(after.point.intensity.numpy(), before.point.intensity.numpy())
    mesh = mesh_files.load_mesh(tmp_path / "mesh.ply")
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(mesh.vertices.astype(np.float32)),
                        o3d.core.Tensor(mesh.faces.astype(np.uint32)))
    distance = scene.compute_distance(after.point.positions).numpy()
    assert np.percentile(distance, 99) < 0.01 * grid.pitch


@pytest.mark.parametrize("points, message", [
    (np.random.default_rng(0).random((500, 3)), "500 points is too sparse"),
    (np.c_[np.random.default_rng(0).random((5000, 2)), np.zeros(5000)], r"lies in a plane \(a flat scan\)"),
    (np.random.default_rng(0).random((1000, 3)) * 100, "too sparse: 1000 distinct points, .* apart on a shape"),
    (np.repeat(np.random.default_rng(0).random((800, 3)), 2, axis=0), "too sparse: 800 distinct points"),
])
def test_clouds_that_make_no_solid_are_refused(tmp_path, points, message):
    o3d.t.io.write_point_cloud(str(tmp_path / "c.pcd"), o3d.t.geometry.PointCloud(
        o3d.core.Tensor(points.astype(np.float32))))
    with pytest.raises(InputError, match=message):
        denoise_file.denoise_file(tmp_path / "c.pcd", tmp_path / "o.ply", DenoiseParams(resolution=32))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.pcd"]


def test_moved_points_need_a_cloud(tmp_path):
    trimesh.creation.box().export(tmp_path / "cube.ply")
    with pytest.raises(InputError, match="moved points need a point cloud input"):
        denoise_file.denoise_file(tmp_path / "cube.ply", tmp_path / "o.ply", DenoiseParams(), points=True)
    assert formats.is_point_cloud(tmp_path / "cube.ply") is False


def _cloud(n=2000, normals=False):
    points = np.random.default_rng(0).random((n, 3)).astype(np.float32)
    cloud = o3d.t.geometry.PointCloud(o3d.core.Tensor(points))
    if normals:
        cloud.point.normals = o3d.core.Tensor(points[:, ::-1].copy())
    return cloud


@pytest.mark.parametrize("ext", ["xyz", "xyzn"])
def test_text_clouds_are_read_as_open3d_reads_them_final_newline_or_not(tmp_path, ext):
    path = tmp_path / f"c.{ext}"
    o3d.t.io.write_point_cloud(str(path), _cloud(normals=ext == "xyzn"))
    theirs = o3d.t.io.read_point_cloud(str(path))
    path.write_text(path.read_text().rstrip("\n"))  # open3d's own reader aborted the process on this
    ours = point_files.load_points(path)
    assert set(ours.point) == set(theirs.point)
    for key in theirs.point:
        assert ours.point[key].dtype == theirs.point[key].dtype
        assert np.array_equal(ours.point[key].numpy(), theirs.point[key].numpy())


@pytest.mark.parametrize("text, message", [("1 2\n" * 1500, "each line must hold 3 numbers"),
                                           ("x y z\n" * 1500, "each line must hold 3 numbers"),
                                           ("", "0 points is too sparse")])
def test_malformed_text_clouds_are_refused(tmp_path, text, message):
    (tmp_path / "c.xyz").write_text(text)
    with pytest.raises(InputError, match=message):
        point_files.load_points(tmp_path / "c.xyz")


def test_a_comment_in_any_encoding_is_skipped(tmp_path):
    path = tmp_path / "c.xyz"
    o3d.t.io.write_point_cloud(str(path), _cloud())
    path.write_bytes(b"# scanned at the caf\xe9\n" + path.read_bytes())
    assert len(point_files.load_points(path).point.positions) == 2000


def test_a_pts_file_holding_fewer_points_than_it_declares_is_refused(tmp_path):
    whole = tmp_path / "whole.pts"
    o3d.t.io.write_point_cloud(str(whole), _cloud())
    assert len(point_files.load_points(whole).point.positions) == 2000
    lines = whole.read_text().splitlines(keepends=True)
    (tmp_path / "cut.pts").write_text("".join(lines[:1500]))
    with pytest.raises(InputError, match="the point cloud is truncated .*declares 2000 points, the file holds 1499"):
        point_files.load_points(tmp_path / "cut.pts")


@pytest.mark.parametrize("options", [{"write_ascii": True}, {"write_ascii": False},
                                     {"write_ascii": False, "compressed": True}], ids=["ascii", "binary", "compressed"])
def test_a_truncated_pcd_is_refused(tmp_path, options):
    whole = tmp_path / "whole.pcd"
    o3d.t.io.write_point_cloud(str(whole), _cloud(), **options)
    assert len(point_files.load_points(whole).point.positions) == 2000
    data = whole.read_bytes()
    (tmp_path / "cut.pcd").write_bytes(data[:len(data) * 2 // 3])
    with pytest.raises(InputError, match="the point cloud is truncated .*declares 2000 points"):
        point_files.load_points(tmp_path / "cut.pcd")


def test_a_cloud_is_read_with_the_standard_output_closed(tmp_path, monkeypatch):
    o3d.t.io.write_point_cloud(str(tmp_path / "c.pcd"), _cloud())
    monkeypatch.setattr("sys.stdout", None)  # Python's stand-in for a descriptor closed at start
    assert len(point_files.load_points(tmp_path / "c.pcd").point.positions) == 2000
