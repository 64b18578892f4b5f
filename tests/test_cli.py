"""The command line: real files in and out, one clear error line on bad input."""

import hashlib
import os
import subprocess
import sys

import numpy as np
import pytest
import trimesh

from skelfilter.cli import commands
from skelfilter.cli import parser as cli_parser
from skelfilter.errors import ResourceError
from skelfilter.runtime.memory import check_grid_fits


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "skelfilter.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=600)


def digest(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


@pytest.fixture(scope="module")
def cube_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("in") / "cube.stl"
    trimesh.creation.box((1.0, 1.2, 0.8)).export(path)
    return path


@pytest.mark.parametrize("ext", ["ply", "obj", "off", "glb"])
def test_denoise_writes_every_format_and_keeps_the_input(cube_file, tmp_path, ext):
    before = digest(cube_file)
    out = tmp_path / f"out.{ext}"
    r = run_cli("denoise", cube_file, out, "--resolution", "32", "--importance", "euclidean")
    assert r.returncode == 0, r.stderr
    assert digest(cube_file) == before
    mesh = trimesh.load(out, force="mesh")
    mesh.merge_vertices()  # the input mesh comes back as it was stored: an STL's triangle soup
    assert mesh.is_watertight
    # the box survives in its own world coordinates (within a voxel)
    pitch = 1.2 / 32
    assert np.allclose(mesh.bounds, [[-0.5, -0.6, -0.4], [0.5, 0.6, 0.4]], atol=1.5 * pitch)
    assert not [p for p in os.listdir(tmp_path) if p.startswith(".skelfilter-")]


def test_save_skeleton_writes_a_point_cloud_with_measures(cube_file, tmp_path):
    out, skel = tmp_path / "out.ply", tmp_path / "skel.ply"
    r = run_cli("noise", cube_file, tmp_path / "noisy.ply", "--resolution", "40", "--seed", "3")
    assert r.returncode == 0, r.stderr
    r = run_cli("denoise", tmp_path / "noisy.ply", out, "--resolution", "40", "--save-skeleton", skel,
                "--preset", "thesis")
    assert r.returncode == 0, r.stderr
    header = open(skel, "rb").read(400).split(b"end_header")[0].decode()
    for name in ("quality", "d", "rho", "sigma_bar", "rho_plus"):
        assert f"property float {name}" in header
    ply = trimesh.load(skel)
    data = ply.metadata["_ply_raw"]["vertex"]["data"]
    stage = np.asarray(data["stage"])
    # MeshLab reads it, with rho+ as the per-vertex quality it colours by
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(skel))
    assert ms.current_mesh().vertex_number() == len(stage)
    assert np.allclose(ms.current_mesh().vertex_scalar_array(), data["rho_plus"])
    fg = ply.vertices[stage == 0]
    assert len(fg) > 100 and (stage == 1).sum() > 100
    # the foreground skeleton lies inside the noisy shape, in world coordinates
    lo, hi = trimesh.load(tmp_path / "noisy.ply").bounds
    assert np.all(fg > lo) and np.all(fg < hi)
    assert np.all(np.abs(fg) < [0.5, 0.6, 0.4], axis=1).mean() > 0.5


def one_error_line(r):
    lines = [line for line in r.stderr.strip().splitlines() if line]
    return r.returncode != 0 and len(lines) == 1 and lines[0].startswith("skelfilter: error:")


def test_missing_file(tmp_path):
    assert one_error_line(run_cli("denoise", tmp_path / "nope.obj", tmp_path / "o.obj"))


def test_unreadable_file(tmp_path):
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 99\ngarbage")
    r = run_cli("denoise", bad, tmp_path / "o.ply")
    assert one_error_line(r)
    assert not (tmp_path / "o.ply").exists()


def test_empty_mesh(tmp_path):
    empty = tmp_path / "empty.obj"
    empty.write_text("# nothing\n")
    assert one_error_line(run_cli("denoise", empty, tmp_path / "o.obj"))


def test_nan_coordinates(tmp_path):
    nan = tmp_path / "nan.obj"
    nan.write_text("v 0 0 0\nv 1 0 0\nv nan 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n")
    r = run_cli("denoise", nan, tmp_path / "o.obj")
    assert one_error_line(r) and "NaN" in r.stderr


def test_resolution_too_small(cube_file, tmp_path):
    assert one_error_line(run_cli("denoise", cube_file, tmp_path / "o.obj", "--resolution", "8"))


def test_resolution_too_large_is_refused_before_allocating(cube_file, tmp_path):
    r = run_cli("denoise", cube_file, tmp_path / "o.obj", "--resolution", "4000")
    assert one_error_line(r) and "GiB" in r.stderr


def test_memory_estimate():
    with pytest.raises(ResourceError):
        check_grid_fits((1000, 1000, 1000), available=10 * 2**30)
    assert check_grid_fits((100, 100, 100), available=10 * 2**30) > 0


def test_refuses_to_overwrite_input(cube_file, tmp_path):
    copy = tmp_path / "same.stl"
    copy.write_bytes(open(cube_file, "rb").read())
    before = digest(copy)
    assert one_error_line(run_cli("denoise", copy, copy, "--resolution", "24"))
    assert digest(copy) == before


def test_flags_come_from_the_parameter_dataclass():
    parser = cli_parser.build_parser()
    args = parser.parse_args(["denoise", "a.obj", "b.obj", "--threshold", "12", "--stages", "foreground",
                              "--edt-filter", "none", "--importance", "estimate", "--skeleton", "ima", "--k", "0.5"])
    params = commands._params(commands.SKELETON_SALIENCY_DENOISE, args)
    assert (params.threshold, params.stages, params.edt_filter, params.importance, params.skeleton, params.k) == (
        12.0, "foreground", "none", "estimate", "ima", 0.5)
    args = parser.parse_args(["noise", "a.obj", "b.obj", "--p", "0.02", "--l", "1", "--dents"])
    noise = commands._params(commands.ADD_SKELETON_NOISE, args)
    assert (noise.p, noise.l, noise.dents) == (0.02, 1, True)


@pytest.mark.parametrize("command", ["denoise", "batch"])
def test_help_shows_the_common_flags_in_plain_words_and_help_all_every_parameter(command, capsys):
    with pytest.raises(SystemExit) as done:
        cli_parser.build_parser().parse_args([command, "--help"])
    assert done.value.code == 0
    short = capsys.readouterr().out
    assert len(short.splitlines()) <= 64
    assert "--resolution" in short and "in voxels" in short and "--help-all" in short
    assert "--threshold" not in short and "eq. 5.6" not in short
    full = run_cli(command, "--help-all")
    assert full.returncode == 0
    assert "--threshold" in full.stdout and "eq. 5.6" in full.stdout and "advanced parameters" in full.stdout
    assert "--stages" in short  # the README's flags are in the short help
    if command == "denoise":
        assert "--save-skeleton" in short and "--save-skeleton" in full.stdout


def test_hidden_flags_still_take_effect(cube_file, tmp_path):
    out = tmp_path / "out.ply"
    done = run_cli("denoise", cube_file, out, "--threshold", "0", "--quiet")
    assert done.returncode == 2 and "threshold" in done.stderr
    assert not out.exists()


def test_preview_draws_the_input_and_the_output_side_by_side(cube_file, tmp_path):
    out, picture = tmp_path / "out.ply", tmp_path / "preview.png"
    r = run_cli("denoise", cube_file, out, "--preview", picture, "--output-mesh", "closed", "--resolution", "32")
    assert r.returncode == 0, r.stderr
    with open(picture, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
    from matplotlib.image import imread
    image = imread(picture)
    height, width = image.shape[:2]
    assert width > 1.8 * height  # two panels in a row
    # something is drawn in each panel: both halves hold pixels darker than the white background
    for half in (image[:, : width // 2], image[:, width // 2:]):
        assert (half[..., :3].mean(axis=2) < 0.9).mean() > 0.01
    assert sorted(os.listdir(tmp_path)) == ["out.ply", "preview.png"]  # and no temporary file left


@pytest.mark.parametrize("name", ["out.ply", "preview.jpg"])
def test_preview_refused_before_anything_runs(cube_file, tmp_path, name):
    out = tmp_path / "out.ply"
    r = run_cli("denoise", cube_file, out, "--preview", tmp_path / name)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert r.stderr.startswith("skelfilter: error:")
    assert not out.exists() and not (tmp_path / "preview.jpg").exists()


def test_preview_of_a_volume(tmp_path):
    mask = np.zeros((24, 24, 24), dtype=bool)
    mask[6:18, 6:18, 6:18] = True
    mask[11:13, 11:13, 18:20] = True  # a spur
    src, out, picture = tmp_path / "mask.npy", tmp_path / "out.npy", tmp_path / "p.png"
    np.save(src, mask)
    r = run_cli("denoise", src, out, "--preview", picture)
    assert r.returncode == 0, r.stderr
    assert out.exists() and picture.stat().st_size > 1000


def test_the_folded_faces_note_says_what_they_are_and_what_to_do(tmp_path):
    from skelfilter.mesh import pipeline as mesh_pipeline

    # a cube with tall bumps, its own mesh kept: where bumps tunnelled, faces stay turned over
    noisy = mesh_pipeline.noisy_mesh(trimesh.creation.box(extents=(1, 1, 1)), resolution=64, p=0.004, l=1, h=4,
                                     seed=3)[0]
    noisy.export(tmp_path / "bumpy.ply")
    r = run_cli("denoise", tmp_path / "bumpy.ply", tmp_path / "out.ply", "--resolution", "64", "--output-mesh",
                "input", "--prune", "as-told", "--noise-height", "7")
    assert r.returncode == 0, r.stderr
    note = next(line for line in r.stderr.splitlines() if " folded (" in line)
    assert "noise" in note and "--output-mesh closed" in note, note
