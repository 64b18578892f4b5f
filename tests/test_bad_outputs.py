"""Outputs that cannot or must not be written, inputs reached under other names, files beside the
output (issue: reliability round 2): one line ``skelfilter: error: …``, exit 2, inputs unchanged,
nothing left behind, no file the run did not make replaced. Full and read-only file systems and
immutable files are made here (a small tmpfs, a read-only bind mount, ``chattr +i``); the tests
that need them are skipped, with the reason, where they cannot be made."""

import contextlib
import hashlib
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest
import trimesh
from PIL import Image

from skelfilter.io import mesh_files
from skelfilter.io.samples import sample_path

SCRIPT = '<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name="Taubin Smooth"/>\n</FilterScript>\n'


def cli(*args, env=None, **kwargs):
    """The CLI in a child process: (exit status, its non-empty stderr lines)."""
    r = subprocess.run([sys.executable, "-m", "skelfilter.cli", *map(str, args)], capture_output=True, text=True,
                       timeout=600, env=env, **kwargs)
    return r.returncode, [line for line in r.stderr.splitlines() if line.strip()]


def refused(args, message, **kwargs):
    status, lines = cli(*args, **kwargs)
    assert status == 2 and len(lines) == 1 and lines[0].startswith("skelfilter: error:"), lines
    assert message in lines[0], lines


def digest(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


def snapshot(folder):
    """Every file under ``folder`` with its hash."""
    return {os.path.relpath(os.path.join(d, n), folder): digest(os.path.join(d, n))
            for d, _, names in os.walk(folder) for n in names}


def textured_box(path):
    mesh = trimesh.creation.box()
    mesh.visual = trimesh.visual.TextureVisuals(uv=np.random.default_rng(1).random((len(mesh.vertices), 2)),
                                                image=Image.new("RGB", (8, 8), (200, 30, 30)))
    mesh_files.save_mesh(mesh, path)


def test_a_textured_obj_brings_its_files_named_after_it(tmp_path):
    src, out = tmp_path / "src", tmp_path / "out"
    src.mkdir()
    out.mkdir()
    textured_box(src / "tex.obj")
    (out / "material.mtl").write_text("mine")
    (out / "material_0.png").write_text("mine too")
    status, _ = cli("denoise", src / "tex.obj", out / "a.obj", "--resolution", "32")
    assert status == 0
    assert sorted(os.listdir(out)) == ["a.mtl", "a.obj", "a_0.png", "material.mtl", "material_0.png"]
    assert (out / "material.mtl").read_text() == "mine" and (out / "material_0.png").read_text() == "mine too"
    assert "mtllib a.mtl" in (out / "a.obj").read_text() and "map_Kd a_0.png" in (out / "a.mtl").read_text()
    assert trimesh.load(out / "a.obj").visual.material.image.size == (8, 8)
    assert cli("denoise", src / "tex.obj", out / "a.obj", "--resolution", "32")[0] == 0  # its own files: replaced
    (out / "b.mtl").write_text("someone's")
    before = snapshot(tmp_path)
    refused(["denoise", src / "tex.obj", out / "b.obj", "--resolution", "32"],
            "b.mtl: exists and is not part of")
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize("name, locale", [(b"caf\xe9", None), ("my café".encode(), "C")])
def test_a_textured_obj_keeps_its_texture_whatever_its_name_and_locale(tmp_path, name, locale):
    # a Latin-1 name (as on a legacy share), and a UTF-8 one with a space under LC_ALL=C
    textured_box(tmp_path / "tex.obj")
    out = os.path.join(os.fsencode(tmp_path), name + b".obj")
    env = dict(os.environ, **({"LC_ALL": locale} if locale else {}))
    try:
        done = subprocess.run([sys.executable, "-m", "skelfilter.cli", "denoise", os.fsencode(tmp_path / "tex.obj"),
                               out, "--resolution", "32", "--output-mesh", "input"], env=env, capture_output=True)
    except (OSError, UnicodeError):
        pytest.skip("this file system takes UTF-8 names only")
    assert done.returncode == 0, done.stderr
    text = open(out, "rb").read()
    assert text.count(b"\nvt ") > 0 and b"mtllib " + name + b".mtl\n" in text
    material = name.replace(b" ", b"_") + b"_0"
    assert b"usemtl " + material in text
    mtl = open(os.path.join(os.fsencode(tmp_path), name + b".mtl"), "rb").read()
    assert b"map_Kd " + material + b".png" in mtl
    assert os.path.exists(os.path.join(os.fsencode(tmp_path), material + b".png"))


def test_a_batch_of_textured_objs_gives_each_its_own_material(tmp_path):
    src, out = tmp_path / "src", tmp_path / "out"
    src.mkdir()
    textured_box(src / "x.obj")
    textured_box(src / "y.obj")
    status, _ = cli("batch", src, "--out", out, "--resolution", "32", "--workers", "1", "--quiet")
    assert status == 0
    assert {"x.obj", "x.mtl", "x_0.png", "y.obj", "y.mtl", "y_0.png"} <= set(os.listdir(out))
    assert "mtllib y.mtl" in (out / "y.obj").read_text()


@pytest.fixture
def alias_folders(tmp_path):
    """A folder with an input, a script and a hard link to the input, and the folder under a symlink."""
    folder = tmp_path / "data"
    folder.mkdir()
    trimesh.creation.box().export(folder / "in.ply")
    os.link(folder / "in.ply", folder / "hardlink.ply")
    (folder / "s.mlx").write_text(SCRIPT)
    os.link(folder / "s.mlx", folder / "s-link.ply")
    (tmp_path / "alias").symlink_to(folder, target_is_directory=True)
    return folder, tmp_path / "alias"


@pytest.mark.parametrize("args, message", [
    (["denoise", "{d}/in.ply", "{d}/hardlink.ply"], "refusing to overwrite the input file"),
    (["denoise", "{d}/in.ply", "{a}/in.ply"], "refusing to overwrite the input file"),
    (["noise", "{d}/in.ply", "{d}/hardlink.ply"], "refusing to overwrite the input file"),
    (["noise", "{a}/in.ply", "{d}/in.ply"], "refusing to overwrite the input file"),
    (["run-script", "{d}/s.mlx", "{d}/in.ply", "{a}/hardlink.ply"], "refusing to overwrite the input file"),
    (["run-script", "{d}/s.mlx", "{d}/in.ply", "{d}/s-link.ply"], "refusing to overwrite the script file"),
    (["denoise", "{d}/in.ply", "{d}/new.ply", "--output-mesh", "closed", "--save-skeleton", "{a}/hardlink.ply"],
     "refusing to overwrite the input file"),
    (["batch", "{d}/in.ply", "--out", "{a}", "--force"], "refusing to overwrite the input file"),
])
def test_the_input_is_known_under_every_name(alias_folders, args, message):
    folder, alias = alias_folders
    before = snapshot(folder)
    refused([a.format(d=folder, a=alias) for a in args], message)
    assert snapshot(folder) == before


@contextlib.contextmanager
def mounted(options, source=None, target=None):
    """A mount made for the test, or a skip saying why it cannot be made."""
    command = ["mount", *options, *([source] if source else []), str(target)]
    try:
        made = subprocess.run(command, capture_output=True, text=True, timeout=30)
    except FileNotFoundError:
        pytest.skip("no mount command")
    if made.returncode != 0:
        pytest.skip(f"cannot mount here ({made.stderr.strip() or made.returncode}): needs root")
    try:
        yield target
    finally:
        subprocess.run(["umount", "-l", str(target)], capture_output=True, timeout=30)


def test_the_input_is_known_through_a_bind_mount(tmp_path):
    folder, view = tmp_path / "data", tmp_path / "view"
    folder.mkdir()
    view.mkdir()
    trimesh.creation.box().export(folder / "in.ply")
    before = digest(folder / "in.ply")
    with mounted(["--bind"], str(folder), view):
        refused(["denoise", folder / "in.ply", view / "in.ply"], "refusing to overwrite the input file")
        refused(["batch", folder, "--out", view, "--force"], "refusing to overwrite the input file")
    assert digest(folder / "in.ply") == before and os.listdir(folder) == ["in.ply"]


def test_a_read_only_file_system_is_said_before_anything_runs(tmp_path):
    source, view = tmp_path / "source", tmp_path / "read-only"
    source.mkdir()
    view.mkdir()
    with mounted(["--bind"], str(source), view):
        made = subprocess.run(["mount", "-o", "remount,bind,ro", str(view)], capture_output=True, timeout=30)
        if made.returncode != 0:
            pytest.skip("cannot remount read-only here")
        refused(["denoise", sample_path(), view / "out.ply"], "read-only file system writing")
        refused(["noise", sample_path(), view / "out.ply"], "read-only file system writing")
        refused(["export-script", "denoise", view / "s.mlx"], "read-only file system writing")
        refused(["batch", sample_path(), "--out", view / "new"], "read-only file system")
        refused(["compare", "--out", view / "report"], "read-only file system")
    assert os.listdir(source) == []


def test_a_full_file_system_is_said_and_nothing_is_left(tmp_path):
    full, private_tmp = tmp_path / "full", tmp_path / "tmp"
    full.mkdir()
    private_tmp.mkdir()
    env = {**os.environ, "TMPDIR": str(private_tmp)}
    with mounted(["-t", "tmpfs", "-o", "size=64k"], "tmpfs", full):
        # the sample comes back as it is (no noise at 32 voxels): some 500 kB, on 64 kB
        refused(["denoise", sample_path(), full / "out.ply", "--resolution", "32"],
                "no space left on device writing", env=env)
        refused(["denoise", sample_path(), full / "out.obj", "--resolution", "32"],
                "no space left on device writing", env=env)
        assert os.listdir(full) == []
    assert os.listdir(private_tmp) == []


def _chattr(flag, path):
    try:
        made = subprocess.run(["chattr", flag, str(path)], capture_output=True, text=True, timeout=30)
    except FileNotFoundError:
        pytest.skip("no chattr command")
    if made.returncode != 0:
        pytest.skip(f"cannot make files immutable here ({made.stderr.strip()})")


def test_immutable_files_and_folders_are_said(tmp_path):
    folder = tmp_path / "locked"
    folder.mkdir()
    (tmp_path / "out.ply").write_text("old")
    _chattr("+i", tmp_path / "out.ply")
    try:
        refused(["denoise", sample_path(), tmp_path / "out.ply"], "operation not permitted (an immutable")
    finally:
        _chattr("-i", tmp_path / "out.ply")
    assert (tmp_path / "out.ply").read_text() == "old"
    _chattr("+i", folder)
    try:
        refused(["denoise", sample_path(), folder / "out.ply"], "operation not permitted (an immutable")
        refused(["export-script", "denoise", folder / "s.mlx"], "operation not permitted (an immutable")
    finally:
        _chattr("-i", folder)
    assert os.listdir(folder) == [] and sorted(os.listdir(tmp_path)) == ["locked", "out.ply"]


@pytest.mark.parametrize("kind", ["fifo", "device"])
def test_a_named_pipe_or_a_device_as_the_output_is_refused_and_left_as_it_is(tmp_path, kind):
    """An atomic write would replace it with a regular file (a pipe another program reads, /dev/null)."""
    if kind == "fifo":
        target = tmp_path / "out.ply"
        os.mkfifo(target)
        refused(["denoise", sample_path(), target], "is a named pipe")
        assert os.path.exists(target) and not os.path.isfile(target)
    else:
        target = tmp_path / "out.ply"
        os.symlink("/dev/null", target)
        refused(["denoise", sample_path(), target], "is a character device")
        assert os.path.islink(target) and not os.path.isfile("/dev/null")


def test_a_closed_pipe_ends_quietly():
    pipeline = f"set -o pipefail; {sys.executable} -m skelfilter.cli filters --meshlab | head -1"
    r = subprocess.run(["bash", "-c", pipeline], capture_output=True, text=True, timeout=300)
    assert r.returncode == 141 and r.stderr == "" and r.stdout.startswith("Skeleton Saliency Denoise")


def test_a_ply_naming_a_missing_texture_warns_in_one_line(tmp_path):
    text = trimesh.creation.box().export(file_type="ply", encoding="ascii").decode()
    header = "format ascii 1.0\n"
    (tmp_path / "tex.ply").write_text(text.replace(header, header + "comment TextureFile missing.png\n", 1))
    status, lines = cli("denoise", tmp_path / "tex.ply", tmp_path / "out.ply", "--resolution", "32")
    warnings = [line for line in lines if "warning" in line]
    assert status == 0 and warnings == ["skelfilter: warning: " + str(tmp_path / "tex.ply")
                                        + ": its texture missing.png is missing; the mesh is read without it"]
    assert not any("Traceback" in line or line.startswith(" ") for line in lines)


@pytest.mark.parametrize("library, texture, warning", [
    (b"gone.mtl", b"t.png", "its material library 'gone.mtl' is missing; the mesh is read without its materials"),
    (b"m.mtl", b"gone.png", "its texture 'gone.png' is missing; the mesh is read without it"),
    (b"m.mtl", b"t\xe9.png", "its texture 't\xe9.png' has a name that is not UTF-8; the mesh is read without it"),
    (b"../m.mtl", b"t.png", "its material library '../m.mtl' lies outside the file's folder (not read)"),
    (b"m.mtl", b"t.png", None)], ids=["missing-library", "missing-texture", "latin1-texture", "outside", "whole"])
def test_an_obj_whose_materials_cannot_be_read_warns_in_one_line(tmp_path, library, texture, warning):
    folder = tmp_path / "in"
    folder.mkdir()
    box = trimesh.creation.box()
    uv = "".join(f"vt {u:g} {v:g}\n" for u, v in box.vertices[:, :2] + 0.5)
    faces = "".join(f"f {a}/{a} {b}/{b} {c}/{c}\n" for a, b, c in box.faces + 1)
    (folder / "a.obj").write_bytes(b"mtllib " + library + b"\nusemtl m\n" + trimesh.exchange.obj.export_obj(
        box, include_normals=False).encode() + uv.encode() + b"usemtl m\n" + faces.encode())
    for where in (folder / "m.mtl", tmp_path / "m.mtl"):
        where.write_bytes(b"newmtl m\nKd 1 0 0\nmap_Kd " + texture + b"\n")
    Image.new("RGB", (4, 4), (255, 0, 0)).save(folder / "t.png")
    status, lines = cli("denoise", folder / "a.obj", tmp_path / "out.ply", "--resolution", "32")
    warnings = [line for line in lines if "warning" in line]
    expected = [] if warning is None else [f"skelfilter: warning: {folder / 'a.obj'}: {warning}"]
    assert status == 0 and [w[:len(e)] for w, e in zip(warnings, expected)] == expected and \
        len(warnings) == len(expected), lines


def test_a_meshlab_ply_with_per_wedge_texture_coordinates_is_read(tmp_path):
    pymeshlab = pytest.importorskip("pymeshlab")
    box = trimesh.creation.box()
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(box.vertices, box.faces))
    ms.compute_texcoord_parametrization_triangle_trivial_per_wedge(textdim=64)
    ms.save_current_mesh(str(tmp_path / "wedge.ply"), save_wedge_texcoord=True, binary=False)
    assert "property list uchar float texcoord" in (tmp_path / "wedge.ply").read_text(errors="replace")
    mesh = mesh_files.load_mesh(tmp_path / "wedge.ply")
    assert (len(mesh.vertices), len(mesh.faces)) == (8, 12)
    status, lines = cli("denoise", tmp_path / "wedge.ply", tmp_path / "out.ply", "--resolution", "32")
    assert status == 0 and any("per-wedge texture coordinates are not kept" in line for line in lines), lines


def test_nrrd_data_beside_its_header_is_read(tmp_path):
    (tmp_path / "sub").mkdir()
    cube = np.zeros((24, 24, 24), np.uint8)
    cube[4:20, 4:20, 4:20] = 1
    (tmp_path / "sub" / "data.raw").write_bytes(cube.tobytes(order="F"))
    (tmp_path / "vol.nrrd").write_text("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 24 24 24\nencoding: raw\n"
                                       "data file: sub/data.raw\n\n")
    status, _ = cli("denoise", tmp_path / "vol.nrrd", tmp_path / "out.nrrd", "--quiet")
    assert status == 0
    head = (tmp_path / "out.nrrd").read_bytes()[:400]
    assert b"data file" not in head and b"datafile" not in head  # the output holds its own data


def test_a_compressed_nifti_claiming_more_than_the_memory_is_refused_unread(tmp_path):
    import gzip

    import nibabel

    image = nibabel.Nifti1Image(np.zeros((2, 2, 2), np.int32), np.eye(4))
    image.header.set_data_shape((1024, 1024, 1024))  # 4 GiB of int32, inflated from a few bytes
    with gzip.open(tmp_path / "bomb.nii.gz", "wb") as f:
        f.write(image.header.binaryblock + b"\0" * 4 + b"\0" * 4096)

    def limit():
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, 3 * 2**30))

    refused(["denoise", tmp_path / "bomb.nii.gz", tmp_path / "out.nii.gz"],
            "the header claims a 1024x1024x1024 volume of 4-byte values, 4.0 GiB, but only", preexec_fn=limit)
    assert sorted(os.listdir(tmp_path)) == ["bomb.nii.gz"]


def test_batch_leaves_no_scratch_files(tmp_path):
    private_tmp = tmp_path / "tmp"
    private_tmp.mkdir()
    abandoned = private_tmp / "skelfilter-dask-999999999-x"  # a run killed outright: no such process now
    (abandoned / "dask-scratch-space").mkdir(parents=True)
    status, _ = cli("batch", sample_path(), "--out", tmp_path / "out", "--resolution", "32", "--workers", "1",
                    "--quiet", env={**os.environ, "TMPDIR": str(private_tmp)})
    assert status == 0 and os.listdir(private_tmp) == []


def test_an_old_tbb_says_nothing_through_the_python_api():
    code = """
import warnings
import numba.np.ufunc.parallel as parallel
from numba import NumbaWarning

def old_tbb():  # what numba does on finding TBB 2021.5
    warnings.warn(NumbaWarning("The TBB threading layer requires TBB version 2021 update 6 or later i.e., "
                               "TBB_INTERFACE_VERSION >= 12060. Found TBB_INTERFACE_VERSION = 12050. The TBB "
                               "threading layer is disabled."))
    raise ImportError("Problem with TBB")

parallel._check_tbb_version_compatible = old_tbb
import trimesh
from skelfilter import denoise_mesh
with warnings.catch_warnings(record=True) as seen:
    warnings.simplefilter("always")
    denoise_mesh(trimesh.creation.box(), resolution=32)
print([str(w.message) for w in seen])
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == "[]", r.stdout + r.stderr


TINY_COMPARISON = os.path.join(os.path.dirname(__file__), "data", "tiny-comparison.toml")


def test_compare_replaces_only_what_an_earlier_run_made(tmp_path):
    config, out = tmp_path / "tiny.toml", tmp_path / "out"
    shutil.copy(TINY_COMPARISON, config)
    (out / "cube").mkdir(parents=True)
    (out / "cube" / "mine.txt").write_text("mine")
    refused(["compare", config, "--out", out, "--quiet"], "cube: exists and was not made by an earlier skelfilter")
    assert snapshot(out) == {"cube/mine.txt": digest(out / "cube" / "mine.txt")}
    os.remove(out / "cube" / "mine.txt")
    os.rmdir(out / "cube")
    (out / "report.html").write_text("my own report")
    refused(["compare", config, "--out", out, "--quiet"], "report.html: exists and was not made by an earlier")
    os.remove(out / "report.html")
    (out / "notes.txt").write_text("mine")
    assert cli("compare", config, "--out", out, "--quiet")[0] == 0
    assert {"report.html", "results.json", "cube", "notes.txt"} <= set(os.listdir(out))
    (out / "cube" / "mine.txt").write_text("mine")  # into a folder the run made
    assert cli("compare", config, "--out", out, "--quiet")[0] == 0  # the earlier run's files are replaced
    assert (out / "cube" / "mine.txt").read_text() == "mine" and (out / "notes.txt").read_text() == "mine"
    assert not [name for name in os.listdir(out) if name.startswith(".")]
