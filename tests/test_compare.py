"""The comparison harness: configuration checks, one tiny run end to end, the report in Chromium."""

import json
import os
import shutil
import subprocess

import numpy as np
import pytest
import trimesh
from conftest import skelfilter_command
from PIL import Image

from skelfilter.errors import InputError, ParameterError
from skelfilter.evaluation.comparison import report
from skelfilter.evaluation.comparison.config import Method, default_config_path, load_config
from skelfilter.evaluation.comparison.methods import run_method
from skelfilter.evaluation.comparison.run import run_compare

HERE = os.path.dirname(os.path.abspath(__file__))
SMOKE = os.path.join(HERE, "..", "skelfilter", "evaluation", "comparison", "smoke.toml")
SCRIPTS = os.path.join(HERE, "..", "skelfilter", "evaluation", "comparison", "scripts")


def _write(tmp_path, text):
    path = tmp_path / "c.toml"
    path.write_text(text)
    return str(path)


def test_default_config_is_the_thesis_protocol():
    cfg = load_config(default_config_path())
    thesis = (0.014, 2.1, 3, 6)
    stripes = [c for c in cfg.cases if c.synthetic and (c.noise.p, c.noise.r, c.noise.h, c.noise.l) == thesis]
    assert {c.model.rsplit("/", 1)[-1] for c in stripes} >= {"cube", "fandisk", "stanford-bunny.obj", "rocker-arm.obj"}
    assert any(c.synthetic and (c.noise.p, c.noise.h, c.noise.l) == (0.01, 7, 4) for c in cfg.cases)
    assert any(c.synthetic and c.noise.dents for c in cfg.cases)
    assert any(not c.synthetic and "twelve-impulsive" in c.noisy for c in cfg.cases)
    scripts = {os.path.basename(m.script) for m in cfg.methods if m.kind == "meshlab"}
    assert scripts >= {"laplacian_surface_preserving.mlx", "two_step.mlx", "mls_apss.mlx", "rimls.mlx", "taubin.mlx"}
    assert {m.kind for m in cfg.methods} == {"noisy", "clean", "skelfilter", "meshlab", "meshlib"}
    # both presets side by side: the default and the thesis' pipeline with its defaults
    presets = [cfg.denoise_params(m) for m in cfg.methods if m.kind == "skelfilter"]
    assert [p.preset for p in presets] == ["default", "thesis"]
    assert presets[1].threshold_voxels == 18 and presets[1].stages == "both"


@pytest.mark.parametrize("text, fragment", [
    ("[run]\nresolutoin = 3\n", "unknown key(s) resolutoin"),
    ("[[case]]\nname='a'\nmodel='cube'\nnoise={p=2}\n[[method]]\nname='n'\nkind='noisy'\n", "case 1 (a): noise"),
    ("[[case]]\nname='a'\nmodel='nowhere.obj'\n[[method]]\nname='n'\nkind='noisy'\n", "no such file"),
    ("[[case]]\nname='a'\nmodel='cube'\n[[method]]\nname='m'\nkind='magic'\n", "method 1 (m): kind must be"),
    ("[[case]]\nname='a'\nmodel='cube'\n[[method]]\nname='s'\nkind='skelfilter'\nparams={k=1,bogus=2}\n",
     "method 1 (s): params"),
    ("[[case]]\nname='a'\nmodel='cube'\n[[method]]\nname='n'\nkind='noisy'\n[sweep]\ncase='b'\nthresholds=[1]\n",
     "[sweep]"),
    ("[[method]]\nname='n'\nkind='noisy'\n", "at least one [[case]]"),
])
def test_config_errors_name_the_entry(tmp_path, text, fragment):
    with pytest.raises(ParameterError) as err:
        load_config(_write(tmp_path, text))
    assert fragment in str(err.value)


def test_config_unreadable(tmp_path):
    with pytest.raises(InputError, match="not valid TOML"):
        load_config(_write(tmp_path, "[run\n"))
    with pytest.raises(InputError, match="no such configuration"):
        load_config(str(tmp_path / "missing.toml"))


def test_a_crashing_filter_becomes_a_failure(meshlab_fault):
    cfg = load_config(SMOKE)
    cube_mesh = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    meshlab_fault("abort")
    method = Method("Laplacian", "meshlab", os.path.join(SCRIPTS, "laplacian_surface_preserving.mlx"), {})
    outcome = run_method(method, cube_mesh, cube_mesh, cfg)
    assert outcome.mesh is None and "crashed" in outcome.error and "signal 6" in outcome.error


def test_best_values_and_failures_in_tables():
    case = {"methods": [
        {"name": "noisy", "kind": "noisy", "seconds": 0.0, "error": None, "metrics": {"chamfer": 0.0}},
        {"name": "a", "kind": "meshlab", "seconds": 2.0, "error": None, "metrics": {"chamfer": 1.5}},
        {"name": "b", "kind": "skelfilter", "seconds": 1.0, "error": None, "metrics": {"chamfer": 0.5}},
        {"name": "c", "kind": "meshlab", "seconds": 9.0, "error": "crashed: SIGSEGV"},
    ]}
    rows = {name: (cells, error) for name, cells, error in report.table_rows(case, ["chamfer", "seconds"])}
    assert rows["b"][0] == [("0.500", True), ("1.0", True)]
    assert rows["a"][0] == [("1.500", False), ("2.0", False)]
    assert rows["noisy"][0][0] == ("0.000", False)  # references never win
    assert rows["c"] == ([], "crashed: SIGSEGV")


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("compare"))
    said = []
    results = run_compare(load_config(SMOKE), out, said.append)
    results["said"] = said
    return out, results


def _entry(results, case, method):
    c = next(c for c in results["cases"] if c["name"] == case)
    return next(m for m in c["methods"] if m["name"] == method)


def test_smoke_run_measures_every_method(smoke):
    out, results = smoke
    with open(os.path.join(out, "results.json")) as f:
        assert json.load(f)["cases"][0]["name"] == "cube"
    for case in results["cases"]:
        for m in case["methods"]:
            assert m["error"] is None, (case["name"], m["name"], m["error"])
            assert os.path.isfile(os.path.join(out, m["mesh"]))
    clean, noisy = _entry(results, "cube", "clean")["metrics"], _entry(results, "cube", "noisy")["metrics"]
    skel = _entry(results, "cube", "skelfilter")["metrics"]
    assert clean["noise_removed"] == 1.0 and clean["chamfer"] < 0.01 and clean["iou"] > 0.99
    assert noisy["noise_removed"] < 0.02 and noisy["chamfer"] > 0.3
    assert skel["noise_removed"] > noisy["noise_removed"] + 0.2 and skel["watertight"]
    real = _entry(results, "twelve-impulsive", "MeshLib")["metrics"]
    assert "noise_removed" not in real and real["chamfer"] > 0
    rows = open(os.path.join(out, "metrics.csv")).read().splitlines()
    assert len(rows) == 1 + sum(len(c["methods"]) for c in results["cases"])
    # it says what it will run and, after each model but the last, how long the others should take
    models = len(results["cases"])
    assert results["said"][0].startswith(f"{models} models x ")
    assert sum("models done, about" in line for line in results["said"]) == models - 1
    sweep = results["sweep"]["rows"]
    assert [r["t"] for r in sweep] == [4, 8, 12]
    assert all(0 <= r["reconstruction_error"] <= 1 and 0 <= r["bumps_removed"] <= 1 for r in sweep)


def test_smoke_pictures_show_meshes(smoke):
    out, results = smoke
    for case in results["cases"]:
        for m in case["methods"]:
            for kind, path in m["images"].items():
                img = np.asarray(Image.open(os.path.join(out, path)).convert("L"), dtype=float)
                covered = (img < 245).mean()  # the background is white
                assert 0.03 < covered < 0.97 and img.std() > 10, (case["name"], m["name"], kind, covered)
    md = open(os.path.join(out, "report.md")).read()
    assert "| cube | skelfilter |" in md and "![sweep](sweep.png)" in md and "**" in md
    assert "- what skelfilter ran: " in md  # the route, as the CLI tells it


def test_report_opens_in_headless_chromium(smoke, tmp_path):
    out, _ = smoke
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    assert browser, "chromium is not installed: run `make setup` (it installs Debian's chromium package)"
    url = "file://" + os.path.abspath(os.path.join(out, "report.html"))
    flags = [browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--hide-scrollbars",
             f"--user-data-dir={tmp_path / 'profile'}"]
    dom = subprocess.run(flags + ["--virtual-time-budget=10000", "--dump-dom", url], capture_output=True,
                         text=True, timeout=120).stdout
    assert "skelfilter against MeshLab" in dom
    total = int(dom.split('data-images-total="')[1].split('"')[0])
    loaded = int(dom.split('data-images-loaded="')[1].split('"')[0])
    assert total > 20 and loaded == total
    shot = tmp_path / "page.png"
    subprocess.run(flags + ["--window-size=1280,1600", f"--screenshot={shot}", url], capture_output=True,
                   timeout=120, check=True)
    page = np.asarray(Image.open(shot).convert("L"), dtype=float)
    assert page.std() > 20 and (page < 128).mean() > 0.01  # text, tables and pictures, not a blank page


# ------------------------------------------------------------------------------ a user's own meshes

TWELVE = os.path.join(HERE, "..", "skelfilter", "data", "twelve-impulsive")
USER_METHODS = ["input", "skelfilter", "Laplacian", "Two-step", "MLS (APSS)", "RIMLS"]


def _compare(args, cwd):
    proc = subprocess.run([skelfilter_command(), "compare", *args, "--quiet"], capture_output=True, text=True, cwd=cwd,
                          timeout=600)
    return proc


@pytest.fixture(scope="module")
def own_mesh(tmp_path_factory):
    """`skelfilter compare FOLDER --out r` on a folder with one noisy mesh (and a text file) in it."""
    work = tmp_path_factory.mktemp("own")
    (work / "scans").mkdir()
    shutil.copy(os.path.join(TWELVE, "noisy.obj"), work / "scans" / "part.obj")
    (work / "scans" / "notes.txt").write_text("not a mesh")
    proc = _compare(["scans", "--out", "r"], work)
    with open(work / "r" / "results.json") as f:
        return work / "r", proc, json.load(f)


def test_compare_of_a_mesh_alone_needs_no_configuration(own_mesh):
    out, proc, results = own_mesh
    assert proc.returncode == 0 and proc.stderr == "", proc.stderr  # no VTK warning either
    (case,) = results["cases"]
    assert case["name"] == "part.obj" and case["reference"] == "input"
    assert [m["name"] for m in case["methods"]] == USER_METHODS
    measured = {m["name"]: m["metrics"] for m in case["methods"]}
    for name, m in measured.items():
        assert {"roughness_deg", "moved_mean", "volume_change", "normal_change_deg"} <= set(m), name
        assert "chamfer" not in m  # nothing to measure it against
    assert measured["input"]["moved_mean"] < 1e-4 and measured["input"]["volume_change"] == 0
    # every filter smooths the impulsive noise: rougher input than any result
    assert all(measured[n]["roughness_deg"] < measured["input"]["roughness_deg"] for n in USER_METHODS[1:])
    assert case["closeup"] == "where the filters' results differ most"
    md = (out / "report.md").read_text()
    assert "The meshes given, each as it is" in md and "| part.obj | skelfilter |" in md
    assert "roughness (°)" in md and "volume change" in md


def test_compare_pictures_of_a_mesh_alone_show_it(own_mesh):
    out, _, results = own_mesh
    for m in results["cases"][0]["methods"]:
        for kind, path in m["images"].items():
            img = np.asarray(Image.open(out / path).convert("L"), dtype=float)
            covered = (img < 245).mean()
            assert 0.05 < covered < 0.97 and img.std() > 10, (m["name"], kind, covered)


def test_compare_with_a_clean_mesh_gives_the_full_table(tmp_path):
    proc = _compare([os.path.join(TWELVE, "noisy.obj"), "--clean", os.path.join(TWELVE, "clean.obj"),
                     "--out", "r", "--jobs", "2"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    with open(tmp_path / "r" / "results.json") as f:
        (case,) = json.load(f)["cases"]
    assert case["reference"] == "clean" and [m["name"] for m in case["methods"]] == USER_METHODS + ["clean"]
    measured = {m["name"]: m["metrics"] for m in case["methods"]}
    assert measured["clean"]["chamfer"] < 0.01 and measured["skelfilter"]["chamfer"] < measured["input"]["chamfer"]
    assert "normal_error_deg" in measured["RIMLS"]


@pytest.mark.parametrize("args, fragment", [
    (["a.obj", "b.obj", "--clean", "a.obj"], "a clean mesh belongs to one noisy mesh, got 2"),
    (["c.toml", "a.obj"], "a TOML configuration names its own meshes"),
    (["--clean", "a.obj"], "--clean: give the noisy mesh it belongs to"),
    (["v.npy"], "v.npy: not a mesh"),
    (["a.obj", "--clean", "missing.obj"], "missing.obj: no such file"),
])
def test_compare_refuses_what_it_cannot_do(tmp_path, args, fragment):
    for name in ("a.obj", "b.obj"):
        shutil.copy(os.path.join(TWELVE, "noisy.obj"), tmp_path / name)
    (tmp_path / "c.toml").write_text("")
    np.save(tmp_path / "v.npy", np.zeros((4, 4, 4), bool))
    proc = _compare(args + ["--out", "r"], tmp_path)
    assert proc.returncode != 0 and proc.stderr.startswith("skelfilter: error: ") and fragment in proc.stderr, \
        proc.stderr
    assert not (tmp_path / "r").exists()


def test_the_chosen_view_sees_the_broad_side_with_the_features():
    import manifold3d

    from skelfilter.evaluation import camera

    plate = manifold3d.Manifold.cube((1.0, 1.0, 0.1), True)  # broad in x and y
    bumps = [manifold3d.Manifold.sphere(0.06, 24).translate((x, y, 0.05))
             for x in (-0.3, 0.0, 0.3) for y in (-0.3, 0.0, 0.3)]  # relief on the +z side only
    solid = manifold3d.Manifold.batch_boolean([plate] + bumps, manifold3d.OpType.Add).to_mesh()
    shape = trimesh.Trimesh(np.asarray(solid.vert_properties)[:, :3], np.asarray(solid.tri_verts))
    view = camera.view_for(shape, up=(0.0, 1.0, 0.0))
    assert view[2] > 0.8  # from +z: the broad side, where the relief is
    flipped = shape.copy()
    flipped.apply_transform(trimesh.transformations.rotation_matrix(np.pi, (0, 1, 0)))
    assert camera.view_for(flipped, up=(0.0, 1.0, 0.0))[2] < -0.8
    assert camera.up_for("part.STL") == (0.0, 0.0, 1.0) and camera.up_for("bunny.ply") == (0.0, 1.0, 0.0)


def test_preview_shows_the_broad_side_well_lit(tmp_path):
    """``denoise --preview`` takes compare's camera: a y-up plate with relief on one side is seen
    face on from that side, not edge on, and its lit side is bright."""
    import manifold3d

    plate = manifold3d.Manifold.cube((1.0, 1.0, 0.1), True)
    bumps = [manifold3d.Manifold.sphere(0.06, 24).translate((x, y, 0.05)) for x in (-0.3, 0.3) for y in (-0.3, 0.3)]
    solid = manifold3d.Manifold.batch_boolean([plate] + bumps, manifold3d.OpType.Add).to_mesh()
    trimesh.Trimesh(np.asarray(solid.vert_properties)[:, :3], np.asarray(solid.tri_verts)).export(tmp_path / "p.ply")
    proc = subprocess.run([skelfilter_command(), "denoise", "p.ply", "out.ply", "--preview", "v.png", "--quiet"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    image = np.asarray(Image.open(tmp_path / "v.png").convert("L"), dtype=float)
    panel = image[int(0.1 * len(image)):, : image.shape[1] // 2]  # the input, below its title
    covered = panel < 245
    assert covered.mean() > 0.25, covered.mean()  # face on: the plate fills the panel
    assert np.median(panel[covered]) > 150, np.median(panel[covered])  # lit, not dark
