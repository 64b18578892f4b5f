"""skelfilter batch on a Dask LocalCluster: good files done, bad ones reported, a dead worker's task
retried then reported, a rerun skips what is there."""

import csv
import hashlib
import json
import os
import subprocess
import sys

import numpy as np
import pytest
import trimesh

import harness
from skelfilter.errors import InputError, ParameterError
from skelfilter.io import mesh_files
from skelfilter.jobs import batch


def digest(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("batch-in")
    rng = np.random.default_rng(0)
    for i in range(6):
        mesh = trimesh.creation.icosphere(subdivisions=3) if i % 2 else trimesh.creation.box()
        mesh = mesh.subdivide() if i % 2 == 0 else mesh
        mesh.vertices = mesh.vertices + rng.normal(0, 0.01, mesh.vertices.shape)
        mesh.export(root / f"mesh{i}.{('ply', 'obj', 'stl')[i % 3]}")
    np.save(root / "ball.npy", (np.indices((40, 40, 40)) - 19.5).__pow__(2).sum(0) < 14**2)
    (root / "corrupt.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 99\ngarbage")
    trimesh.creation.box().export(root / "dies.ply")
    (root / "notes.txt").write_text("not a mesh: a folder's other files are left out")
    return root


def run_batch(*args, kill=None):
    """``skelfilter batch`` with ``args``; ``kill``: the input file whose worker kills itself (`harness`)."""
    command = [sys.executable, harness.__file__, "batch-kill", kill, "--"] if kill else [
        sys.executable, "-m", "skelfilter.cli"]
    return subprocess.run([*command, "batch", *map(str, args)], capture_output=True, text=True, timeout=600,
                          env=harness.with_harness_path(dict(os.environ)))


def test_batch_reports_failures_and_a_rerun_skips_what_is_done(inputs, tmp_path):
    out = tmp_path / "out"
    r = run_batch(inputs, "--out", out, "--workers", "2", "--resolution", "32",
                  kill="dies.ply")
    assert r.returncode == 1, r.stderr
    rows = {os.path.basename(row["input"]): row for row in csv.DictReader(open(out / "summary.csv"))}
    assert rows == {os.path.basename(row["input"]): {k: str(v) for k, v in row.items()}
                    for row in json.load(open(out / "summary.json"))}
    assert set(rows) == {f"mesh{i}.{('ply', 'obj', 'stl')[i % 3]}" for i in range(6)} | {
        "ball.npy", "corrupt.ply", "dies.ply"}
    assert rows["corrupt.ply"]["status"] == "failed" and "malformed PLY file" in rows["corrupt.ply"]["error"]
    assert rows["dies.ply"]["status"] == "failed" and "worker died" in rows["dies.ply"]["error"]
    good = [name for name, row in rows.items() if name not in ("corrupt.ply", "dies.ply")]
    assert all(rows[name]["status"] == "ok" and float(rows[name]["peak_memory_mib"]) > 0 for name in good)
    for name in good:  # present and complete
        if name.endswith(".npy"):
            assert np.load(out / name).shape == (40, 40, 40)
        else:
            assert len(mesh_files.load_mesh(out / name).faces) > 0
    assert not (out / "corrupt.ply").exists() and not (out / "dies.ply").exists()
    assert sorted(os.listdir(out)) == sorted(good + ["summary.csv", "summary.json"])
    before = {name: (digest(out / name), os.stat(out / name).st_mtime_ns) for name in good}

    again = run_batch(inputs, "--out", out, "--workers", "2", "--resolution", "32", "--quiet")
    assert again.returncode == 1  # the corrupt file is still reported, in one line under --quiet too
    assert again.stderr.startswith("skelfilter: error: 1 of 9 files failed, the first ") and \
        again.stderr.count("\n") == 1 and "corrupt.ply: malformed PLY file" in again.stderr, again.stderr
    rows = {os.path.basename(row["input"]): row for row in csv.DictReader(open(out / "summary.csv"))}
    assert all(rows[name]["status"] == "skipped" for name in good)
    assert rows["dies.ply"]["status"] == "ok"  # a dead worker is worth another try
    assert rows["corrupt.ply"]["status"] == "failed" and rows["corrupt.ply"]["seconds"] == "0.0"  # carried over
    assert {name: (digest(out / name), os.stat(out / name).st_mtime_ns) for name in good} == before

    # A third run has nothing left to do: no cluster, nothing written but the summary.
    third = run_batch(inputs, "--out", out, "--resolution", "32")
    rows = {os.path.basename(row["input"]): row for row in csv.DictReader(open(out / "summary.csv"))}
    assert third.returncode == 1 and "0 denoised, 8 skipped" in third.stderr
    assert [row["status"] for row in rows.values()].count("skipped") == 8
    (inputs / "corrupt.ply").touch()  # changed: tried again
    fourth = run_batch(inputs, "--out", out, "--resolution", "32", "--workers", "1")
    assert fourth.returncode == 1 and "0 denoised, 8 skipped (output there), 1 failed" in fourth.stderr


def test_python_api_and_bad_batches(inputs, tmp_path):
    rows = batch.denoise_many([str(inputs / "mesh1.obj"), str(inputs / "ball.npy")], str(tmp_path), workers=1,
                              resolution=32, to="ply", spacing=(1.0, 1.0, 2.0),  # the spacing: for the volume
                              output_mesh="closed")  # and the mesh output's choice for the mesh
    assert [row["status"] for row in rows] == ["ok", "ok"]
    assert mesh_files.load_mesh(tmp_path / "ball.ply").is_watertight  # a volume to a mesh
    with pytest.raises(InputError, match="no such file or folder"):
        batch.denoise_many([str(inputs / "missing.ply")], str(tmp_path))
    with pytest.raises(InputError, match="the pattern matches no file"):
        batch.denoise_many([str(inputs / "*.xyz")], str(tmp_path))
    (tmp_path / "elsewhere").mkdir()
    trimesh.creation.box().export(tmp_path / "elsewhere" / "mesh0.ply")
    with pytest.raises(InputError, match="would both write"):
        batch.denoise_many([str(inputs / "mesh0.ply"), str(tmp_path / "elsewhere")], str(tmp_path / "o"))
    with pytest.raises(ParameterError, match=r"k must be a number in \[0, 100\]"):
        batch.denoise_many([str(inputs / "mesh0.ply")], str(tmp_path / "o"), k=-1)
    with pytest.raises(ParameterError, match="unknown parameter nosuch"):
        batch.denoise_many([str(inputs / "mesh0.ply")], str(tmp_path / "o"), nosuch=1)
    assert not (tmp_path / "o").exists()


def test_the_progress_bar_takes_the_standard_error_as_it_is_when_asked(monkeypatch):
    import io

    monkeypatch.setattr("sys.stderr", None)  # closed when the command started
    assert batch.progress_bar() is None
    stream = io.StringIO()
    monkeypatch.setattr("sys.stderr", stream)
    batch.progress_bar()({"input": "/a/b.ply", "status": "done", "error": ""}, {"done": 1, "total": 2, "failed": 0})
    assert stream.getvalue() == "[###############---------------] 1/2, 0 failed: b.ply done\n"


def test_a_name_that_is_no_utf8_is_denoised_in_a_batch_with_the_others(tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    odd = os.path.join(str(folder), os.fsdecode(b"caf\xe9.ply"))  # Latin-1 bytes, as on a legacy share
    try:
        trimesh.creation.icosphere(3).export(odd)
    except (OSError, UnicodeError):
        pytest.skip("this file system takes UTF-8 names only")
    trimesh.creation.icosphere(3).export(folder / "good.ply")
    rows = batch.denoise_many([str(folder)], str(tmp_path / "out"), workers=1, resolution=32)
    assert [row["status"] for row in rows] == ["ok", "ok"], rows
    assert sorted(os.listdir(tmp_path / "out")) == sorted([os.path.basename(odd), "good.ply", "summary.csv",
                                                           "summary.json"])
    assert len(mesh_files.load_mesh(os.path.join(str(tmp_path / "out"), os.path.basename(odd))).faces) > 0


def test_keep_tree_mirrors_the_inputs_folders(tmp_path):
    scans = tmp_path / "scans"
    for patient in ("anna", "ben", "ben/followup"):
        (scans / patient).mkdir(parents=True)
        trimesh.creation.icosphere(3).export(scans / patient / "noisy.ply")
    out = tmp_path / "cleaned"
    r = run_batch(scans / "*" / "noisy.ply", "--out", out, "--workers", "1", "--resolution", "32")
    assert r.returncode == 2 and "--keep-tree" in r.stderr and not out.exists()  # they would collide
    r = run_batch(scans / "*" / "noisy.ply", scans / "ben" / "followup", "--out", out, "--workers", "1",
                  "--resolution", "32", "--keep-tree", "--quiet")
    assert r.returncode == 0, r.stderr
    written = sorted(os.path.relpath(os.path.join(d, f), out) for d, _, names in os.walk(out) for f in names)
    assert written == ["anna/noisy.ply", "ben/followup/noisy.ply", "ben/noisy.ply", "summary.csv", "summary.json"]
    rows = {row["input"]: row["output"] for row in csv.DictReader(open(out / "summary.csv"))}
    assert rows[str(scans / "ben" / "followup" / "noisy.ply")] == str(out / "ben" / "followup" / "noisy.ply")


def test_keep_tree_leaves_no_folder_behind_when_refused(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    trimesh.creation.box().export(tmp_path / "a" / "x.ply")
    trimesh.creation.box().export(tmp_path / "b" / "x.ply")
    with pytest.raises(InputError):  # an output format the input cannot become: refused before anything runs
        batch.denoise_many([str(tmp_path / "a"), str(tmp_path / "b")], str(tmp_path / "out"), to="npy",
                           keep_tree=True)
    assert not (tmp_path / "out").exists()


def test_a_cluster_that_cannot_start_is_one_line(tmp_path):
    import resource

    trimesh.creation.box().export(tmp_path / "a.ply")
    out = tmp_path / "out"

    def few_files():
        resource.setrlimit(resource.RLIMIT_NOFILE, (24, resource.getrlimit(resource.RLIMIT_NOFILE)[1]))

    done = subprocess.run([sys.executable, "-m", "skelfilter.cli", "batch", str(tmp_path / "a.ply"), "--out", str(out),
                           "--workers", "1"], capture_output=True, text=True, timeout=300, preexec_fn=few_files)
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines() == [done.stderr.strip()] and "too many open files" in done.stderr
    assert not out.exists()


def _tree(root):
    """root/a.ply, root/sub/b.ply, root/sub/deeper/c.stl, and files a folder's reading leaves out."""
    (root / "sub" / "deeper").mkdir(parents=True)
    (root / ".cache").mkdir()
    for path in (root / "a.ply", root / "sub" / "b.ply", root / "sub" / "deeper" / "c.stl",
                 root / ".cache" / "hidden.ply"):
        trimesh.creation.box().export(path)
    (root / "sub" / "notes.txt").write_text("not a mesh")


def test_a_folder_is_read_with_its_subfolders_mirrored_under_out(tmp_path):
    from skelfilter.jobs import batch_files

    _tree(tmp_path / "scans")
    found = batch_files.expand_inputs([str(tmp_path / "scans")])
    assert found == [str(tmp_path / "scans" / n) for n in ("a.ply", "sub/b.ply", "sub/deeper/c.stl")]
    # with a file named beside it: that one under its own name
    trimesh.creation.box().export(tmp_path / "one.ply")
    outputs = batch_files.output_paths(batch_files.find_inputs([str(tmp_path / "scans"), str(tmp_path / "one.ply")]),
                                       str(tmp_path / "out"))
    assert [os.path.relpath(p, tmp_path / "out") for p in outputs] == ["a.ply", "sub/b.ply", "sub/deeper/c.stl",
                                                                       "one.ply"]


def test_a_double_star_pattern_reaches_every_depth(tmp_path):
    from skelfilter.jobs import batch_files

    _tree(tmp_path / "scans")
    found = batch_files.expand_inputs([str(tmp_path / "scans" / "**" / "*.ply")])
    assert found == [str(tmp_path / "scans" / n) for n in ("a.ply", "sub/b.ply")]
    found = batch_files.expand_inputs([str(tmp_path / "scans" / "**")])
    assert found == [str(tmp_path / "scans" / n) for n in ("a.ply", "sub/b.ply", "sub/deeper/c.stl")]


def test_an_empty_file_at_the_output_is_not_taken_as_done(tmp_path):
    trimesh.creation.icosphere(3).export(tmp_path / "a.ply")
    out = tmp_path / "out"
    out.mkdir()
    (out / "a.ply").write_bytes(b"")  # a copy or a write cut short
    rows = batch.denoise_many([str(tmp_path / "a.ply")], str(out), workers=1)
    assert rows[0]["status"] == "ok", rows
    assert len(mesh_files.load_mesh(out / "a.ply").faces) > 0


def test_a_file_gone_before_its_turn_is_one_line(tmp_path):
    from skelfilter.params import DenoiseParams, VolumeParams

    row = batch._task(str(tmp_path / "gone.ply"), str(tmp_path / "out.ply"), DenoiseParams(), VolumeParams(), 1)
    assert row["status"] == "failed" and row["error"] == f"{tmp_path / 'gone.ply'}: no longer exists", row
    assert not row["bad_input"]  # tried again by a rerun, where it is missing from the start


def test_the_summary_says_what_was_done_to_each_file(tmp_path):
    rng = np.random.default_rng(0)
    sphere = trimesh.creation.icosphere(4)
    sphere.export(tmp_path / "clean.ply")
    sphere.vertices = sphere.vertices + rng.normal(0, 0.01, sphere.vertices.shape)
    sphere.export(tmp_path / "fine.ply")
    np.save(tmp_path / "ball.npy", (np.indices((40, 40, 40)) - 19.5).__pow__(2).sum(0) < 14**2)
    rows = {os.path.basename(r["input"]): r for r in batch.denoise_many([str(tmp_path)], str(tmp_path / "out"),
                                                                        workers=1)}
    assert "the mesh comes back as it was" in rows["clean.ply"]["done"], rows
    assert "smoothed by the fine pass" in rows["fine.ply"]["done"], rows
    assert rows["clean.ply"]["voxels_changed"] == rows["fine.ply"]["voxels_changed"] == ""  # no voxel stage ran
    assert rows["ball.npy"]["voxels_changed"] != "" and rows["ball.npy"]["done"]
    written = {os.path.basename(r["input"]): r for r in csv.DictReader(open(tmp_path / "out" / "summary.csv"))}
    assert written["fine.ply"]["done"] == rows["fine.ply"]["done"]
