"""``skelfilter run-script``: MeshLab's and skelfilter's filters in one .mlx script, with layers."""

import importlib.util
import os
import subprocess
import sys

import numpy as np
import pymeshlab
import pytest
import trimesh

from skelfilter.errors import InputError
from skelfilter.io import mesh_files
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.meshlab import mlx, scripts
from skelfilter.meshlab.descriptions import SKELETON_SALIENCY_DENOISE
from skelfilter.params import DenoiseParams, NoiseParams

SCRIPTS = os.path.join(os.path.dirname(__file__), "..", "meshlab_scripts")
BASELINES = os.path.join(os.path.dirname(__file__), "..", "skelfilter", "evaluation", "comparison", "scripts")
HEAD = "<!DOCTYPE FilterScript>\n<FilterScript>\n"
TAIL = "</FilterScript>\n"


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "skelfilter.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=600)


def one_error_line(r):
    lines = [line for line in r.stderr.strip().splitlines() if line]
    return r.returncode == 2 and len(lines) == 1 and lines[0].startswith("skelfilter: error:")


def make_scripts():
    spec = importlib.util.spec_from_file_location("make_scripts", os.path.join(SCRIPTS, "make_scripts.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def noisy_file(tmp_path_factory):
    """A noisy box as PLY: the thesis' isolated bumps at 48 voxels."""
    path = tmp_path_factory.mktemp("in") / "noisy.ply"
    box = trimesh.creation.box((1.0, 1.2, 0.8))
    noisy = mesh_pipeline.noisy_mesh(box, NoiseParams(resolution=48, seed=1, l=1, p=0.01))[0]
    noisy.export(path)
    return path


def _direct(path, calls):
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    for name, params in calls:
        getattr(ms, name)(**params)
    return ms


def test_pymeshlab_saved_script_gives_what_pymeshlab_gives(noisy_file, tmp_path):
    calls = [("apply_coord_taubin_smoothing", dict(stepsmoothnum=5)),
             ("apply_coord_laplacian_smoothing", dict(stepsmoothnum=2, cotangentweight=False))]
    direct = _direct(noisy_file, calls)
    script = tmp_path / "saved.mlx"
    direct.save_filter_script(str(script))
    expected = direct.current_mesh()
    # in Python: the float64 vertices pymeshlab computes, bit for bit, in pymeshlab's order
    out = scripts.run_filter_script(mesh_files.load_mesh(noisy_file), script)
    assert np.array_equal(out.vertices, expected.vertex_matrix())
    assert np.array_equal(out.faces, expected.face_matrix())
    assert not np.allclose(out.vertices, mesh_files.load_mesh(noisy_file).vertices)  # the filters did something
    # from the command line: the same file as pymeshlab's own script runner writes
    r = run_cli("run-script", script, noisy_file, tmp_path / "out.ply")
    assert r.returncode == 0, r.stderr
    own = pymeshlab.MeshSet()
    own.load_new_mesh(str(noisy_file))
    own.load_filter_script(str(script))
    own.apply_filter_script()
    own.save_current_mesh(str(tmp_path / "own.ply"))
    written, theirs = (trimesh.load(tmp_path / n, process=False) for n in ("out.ply", "own.ply"))
    assert np.array_equal(written.vertices, theirs.vertices)
    assert np.array_equal(written.faces, theirs.faces)


# In a child Python: the script pymeshlab saves after applying each filter named on the command line
# to a small closed mesh, as FOLDER/<filter>.mlx. Each filter's name goes to FOLDER/started first, so
# that a filter that crashes pymeshlab (those needing OpenGL or rasters) is passed over when the
# child is started again; one that runs over 2 s is stopped the same way (faulthandler exits).
_WRITE_SCRIPTS = r"""
import faulthandler, os, sys
import pymeshlab
folder, names = sys.argv[1], sys.argv[2:]
started = os.path.join(folder, "started")
done = set(open(started).read().split()) if os.path.exists(started) else set()
for name in names:
    if name in done:
        continue
    with open(started, "a") as f:
        f.write(name + "\n")
    ms = pymeshlab.MeshSet()
    ms.create_sphere(subdiv=1)
    ms.clear_filter_script()
    faulthandler.dump_traceback_later(2, exit=True)
    try:
        getattr(ms, name)()
    except Exception:  # a mesh this filter cannot take (pymeshlab's exceptions share no base)
        continue
    finally:
        faulthandler.cancel_dump_traceback_later()
    ms.save_filter_script(os.path.join(folder, name + ".mlx"))
"""


@pytest.fixture(scope="module")
def pymeshlab_written(tmp_path_factory):
    """``{pymeshlab filter: the .mlx pymeshlab writes for it}`` for every filter that reads and writes
    no file and that pymeshlab applies to a small closed mesh without other inputs."""
    from skelfilter.meshlab import filter_catalogue

    folder = tmp_path_factory.mktemp("pymeshlab-written")
    names = [n for n in pymeshlab.filter_list() if not filter_catalogue.touches_files(n)]
    for _ in names:  # at most one start per filter
        r = subprocess.run([sys.executable, "-c", _WRITE_SCRIPTS, str(folder), *names], capture_output=True,
                           timeout=600)
        if r.returncode == 0:
            break
    written = {n: folder / f"{n}.mlx" for n in names if (folder / f"{n}.mlx").exists()}
    assert len(written) > 150
    return written


def test_every_filter_name_pymeshlab_writes_resolves_to_its_filter(pymeshlab_written):
    from skelfilter.meshlab import filter_catalogue

    wrong, refused = {}, {}
    for name, path in pymeshlab_written.items():
        written = mlx.parse(mlx.read_bytes(path), str(path))[-1].name
        if filter_catalogue.python_filter_name(written) != name:
            wrong[written] = (name, filter_catalogue.python_filter_name(written))
        try:
            scripts.read_script(path)
        except InputError as exc:
            refused[name] = str(exc)
    assert not wrong
    # the whole script is taken, but for a parameter that pymeshlab's own calls cannot be given
    assert all("pymeshlab cannot take a parameter of type" in error for error in refused.values()), refused


# the filters whose names skelfilter refused though pymeshlab writes them (issue 49)
ONCE_REFUSED = ("meshing_re_orient_faces_coherently", "meshing_surface_subdivision_doo_sabin",
                "meshing_re_orient_faces_by_geometry", "apply_coord_cubic_stylization",
                "apply_coord_developability_of_mesh", "compute_normal_by_function_per_face",
                "compute_scalar_ambient_occlusion", "compute_scalar_by_shape_diameter_function_per_vertex",
                "compute_scalar_by_volumetric_obscurance",
                "compute_scalar_by_heat_geodesic_distance_from_selection_per_vertex",
                "create_dodecahedron_sym", "generate_alpha_wrap")


def test_scripts_pymeshlab_writes_run_with_run_script(pymeshlab_written, tmp_path):
    # one script of them all, on the small sphere pymeshlab wrote them for
    filters = [f for name in ONCE_REFUSED
               for f in mlx.parse(mlx.read_bytes(pymeshlab_written[name]), name)]
    script = tmp_path / "written.mlx"
    script.write_text(mlx.script_text(filters))
    trimesh.creation.icosphere(subdivisions=1).export(tmp_path / "sphere.ply")
    r = run_cli("run-script", script, tmp_path / "sphere.ply", tmp_path / "out.ply")
    assert r.returncode == 0, r.stderr
    assert len(trimesh.load(tmp_path / "out.ply", process=False).faces) > 0


def test_layers_behave_as_in_meshlab(noisy_file, tmp_path):
    script = tmp_path / "layers.mlx"
    params = DenoiseParams(resolution=40, importance="euclidean")
    taubin = mlx.FilterElement("Taubin Smooth", 0, [
        mlx.ParamElement({"name": "stepSmoothNum", "type": "RichInt", "value": "3"}, 0)])
    script.write_text(mlx.script_text([mlx.FilterElement("Duplicate Current layer", 0), taubin,
                                       scripts.filter_element(SKELETON_SALIENCY_DENOISE, params)]))
    mesh = mesh_files.load_mesh(noisy_file)
    layers = scripts.run_steps(scripts.read_script(script), mesh)
    # the copy became current and was smoothed; the original layer 0 is untouched
    assert (len(layers.meshes), layers.current) == (3, 2)
    assert np.array_equal(layers.meshes[0].vertices, mesh.vertices)
    smoothed = _direct(noisy_file, [("apply_coord_taubin_smoothing", dict(stepsmoothnum=3))])
    assert np.array_equal(layers.meshes[1].vertices, smoothed.current_mesh().vertex_matrix())
    # skelfilter's filter added its result as a new, current layer
    denoised = mesh_pipeline.denoise_mesh(layers.meshes[1], params)
    assert np.array_equal(layers.current_mesh.vertices, denoised.vertices)


def test_mixed_script_skeleton_step_equals_skelfilter_denoise(noisy_file, tmp_path):
    gen = make_scripts()
    flags = ["--resolution", "48", "--threshold", "10"]
    assert run_cli("export-script", "denoise", tmp_path / "d.mlx", *flags).returncode == 0
    exported = mlx.parse(mlx.read_bytes(tmp_path / "d.mlx"), "d.mlx")
    script = tmp_path / "mixed.mlx"
    script.write_text(mlx.script_text(gen._saved_filters(gen.MIXED_CLEANUP) + exported))
    r = run_cli("run-script", script, noisy_file, tmp_path / "mixed.ply")
    assert r.returncode == 0, r.stderr
    assert f"wrote {tmp_path / 'mixed.ply'}: layer " in r.stderr  # what it wrote, on a success too
    cleaned = _direct(noisy_file, gen.MIXED_CLEANUP)
    cleaned.save_current_mesh(str(tmp_path / "cleaned.ply"))
    r = run_cli("denoise", tmp_path / "cleaned.ply", tmp_path / "denoised.ply", *flags)
    assert r.returncode == 0, r.stderr
    mixed, denoised = (trimesh.load(tmp_path / n, process=False) for n in ("mixed.ply", "denoised.ply"))
    assert len(mixed.vertices) > 1000
    assert np.array_equal(mixed.vertices, denoised.vertices)
    assert np.array_equal(mixed.faces, denoised.faces)


def test_mixed_example_is_cleanup_denoise_smoothing(noisy_file, tmp_path):
    gen = make_scripts()
    params = DenoiseParams(resolution=48)
    script = tmp_path / "mixed.mlx"
    script.write_text(gen.mixed_example_text(params))
    mesh = mesh_files.load_mesh(noisy_file)
    layers = scripts.run_steps(scripts.read_script(script), mesh)
    cleaned = _direct(noisy_file, gen.MIXED_CLEANUP)  # a MeshSet must outlive its meshes' use
    cleaned_mesh = cleaned.current_mesh()
    cleaned_mesh.compact()
    denoised = mesh_pipeline.denoise_mesh(
        trimesh.Trimesh(cleaned_mesh.vertex_matrix(), cleaned_mesh.face_matrix(), process=False), params)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=denoised.vertices, face_matrix=denoised.faces))
    for name, p in gen.MIXED_SMOOTHING:
        getattr(ms, name)(**p)
    assert (len(layers.meshes), layers.current) == (2, 1)
    assert np.array_equal(layers.current_mesh.vertices, ms.current_mesh().vertex_matrix())


def test_mls_runs_on_the_current_layer(tmp_path):
    script = tmp_path / "mls.mlx"
    apss = mlx.parse(mlx.read_bytes(os.path.join(BASELINES, "mls_apss.mlx")), "mls_apss.mlx")
    script.write_text(mlx.script_text([mlx.FilterElement("Duplicate Current layer", 0)] + apss))
    box = trimesh.creation.box((1.0, 1.2, 0.8)).subdivide().subdivide().subdivide().subdivide()
    rng = np.random.default_rng(3)
    mesh = trimesh.Trimesh(box.vertices + rng.normal(0, 0.01, box.vertices.shape), box.faces, process=False)
    layers = scripts.run_steps(scripts.read_script(script), mesh)
    assert (len(layers.meshes), layers.current) == (2, 1)
    assert np.array_equal(layers.meshes[0].vertices, mesh.vertices)
    projected = layers.current_mesh.vertices
    assert projected.shape == mesh.vertices.shape and np.isfinite(projected).all()
    assert np.array_equal(layers.current_mesh.faces, mesh.faces)
    # projected onto the MLS surface of the box (filter scale 15 rounds its edges): moved, not far.
    # (pymeshlab's APSS is not reproducible to the bit: the same call on the same arrays can differ
    # from run to run, by 1e-5 to 0.06 on a noisy 1.2-long box, so no run is compared with another)
    moved = np.linalg.norm(projected - mesh.vertices, axis=1)
    assert 1e-3 < np.median(moved) < 0.1 and moved.max() < 0.3


BILLION_LAUGHS = ('<?xml version="1.0"?>\n<!DOCTYPE lolz [\n <!ENTITY lol "lol">\n'
                  ' <!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">\n]>\n'
                  '<FilterScript><filter name="&lol2;"/></FilterScript>\n')


def one_filter(name, *params):
    """A script whose filter ``name`` stands on line 3, its ``<Param>``s on lines 4, 5, ..."""
    body = "".join(f"  <Param {p}/>\n" for p in params)
    return HEAD + f' <filter name="{name}">\n{body} </filter>\n' + TAIL


DENOISE = "Skeleton Saliency Denoise"


@pytest.mark.parametrize("text, message", [
    (BILLION_LAUGHS, r"bad.mlx:2: the DOCTYPE declares an internal subset \(<!ENTITY>"),
    ('<!DOCTYPE FilterScript SYSTEM "file:///etc/passwd">\n<FilterScript/>',
     r"bad.mlx:1: the DOCTYPE names an external reference \(file:///etc/passwd\)"),
    (HEAD + ' <filter name="Taubin Smooth">\n  <Param name="mu" value="1" type="RichFloat">\n </filter>\n'
     + TAIL, r"bad.mlx:5: malformed filter script XML \(mismatched tag"),
    (HEAD + ' <filter name="&ent;"/>\n' + TAIL, r"bad.mlx:3: malformed filter script XML \(undefined entity"),
    (HEAD + ' <filter name="Taubin Smooth"/>\n <filter name="Skeleton Denoise"/>\n' + TAIL,
     r"bad.mlx:4: filter 'Skeleton Denoise': unknown filter: not a skelfilter filter"),
    (one_filter("Taubin Smooth", 'name="mu" value="-0.5" type="RichFloat"',
                'name="steps" value="3" type="RichInt"'),
     r"bad.mlx:5: filter 'Taubin Smooth', parameter 'steps': unknown parameter \(pymeshlab's "
     r"apply_coord_taubin_smoothing takes lambda_, mu, stepsmoothnum, selected\)"),
    (one_filter("Taubin Smooth", 'name="stepSmoothNum" value="3" type="RichFloat"'),
     r"bad.mlx:4: filter 'Taubin Smooth', parameter 'stepSmoothNum': wrong type 'RichFloat'; pymeshlab's "
     r"stepsmoothnum is of type int \(RichInt or RichMesh\)"),
    (one_filter("Taubin Smooth", 'name="mu" value="x" type="RichFloat"'),
     r"bad.mlx:4: filter 'Taubin Smooth', parameter 'mu': value='x' is not a number"),
    (one_filter(DENOISE, 'name="treshold" value="9" type="RichFloat"'),
     r"bad.mlx:4: filter 'Skeleton Saliency Denoise', parameter 'treshold': unknown parameter"),
    (one_filter(DENOISE, 'name="resolution" value="64" type="RichFloat"'),
     r"bad.mlx:4: filter 'Skeleton Saliency Denoise', parameter 'resolution': wrong type 'RichFloat'; "
     r"resolution is a RichInt"),
    (one_filter(DENOISE, 'name="stages" value="0" enum_val0="all" type="RichEnum"'),
     r"bad.mlx:4: filter 'Skeleton Saliency Denoise', parameter 'stages': stages must be one of preset, both, "
     r"foreground, background, auto, got 'all'"),
    (one_filter(DENOISE, 'name="resolution" value="8" type="RichInt"'),
     r"bad.mlx:3: filter 'Skeleton Saliency Denoise': resolution must be an integer in \[16, 4096\], got 8"),
    (one_filter("Add Skeleton Noise", 'name="l" value="2" type="RichInt"',
                'name="l" value="3" type="RichInt"'),
     r"bad.mlx:5: filter 'Add Skeleton Noise', parameter 'l': given twice"),
    (HEAD + ' <Filter name="Taubin Smooth"/>\n' + TAIL, r"bad.mlx:3: <Filter> inside <FilterScript>"),
    (HEAD + TAIL, "contains no filters"),
])
def test_bad_scripts_name_the_line_filter_and_parameter(tmp_path, text, message):
    path = tmp_path / "bad.mlx"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        scripts.read_script(path)


@pytest.mark.parametrize("text", [BILLION_LAUGHS,
                                  one_filter("Add Skeleton Noise", 'name="h" value="2.5" type="RichFloat"')])
def test_run_script_refuses_bad_scripts_and_writes_nothing(noisy_file, tmp_path, text):
    path = tmp_path / "bad.mlx"
    path.write_text(text)
    r = run_cli("run-script", path, noisy_file, tmp_path / "out.ply")
    assert one_error_line(r) and "bad.mlx:" in r.stderr
    assert os.listdir(tmp_path) == ["bad.mlx"]


def test_a_failing_filter_midway_writes_nothing(noisy_file, tmp_path):
    path = tmp_path / "fails.mlx"
    path.write_text(HEAD + ' <filter name="Taubin Smooth"/>\n <filter name="Colorize by vertex Quality">\n'
                    '  <Param name="colorMap" value="0" enum_val0="NoSuchMap" type="RichEnum"/>\n'
                    ' </filter>\n' + TAIL)
    r = run_cli("run-script", path, noisy_file, tmp_path / "out.ply")
    assert one_error_line(r)
    assert "fails.mlx:4: filter 'Colorize by vertex Quality'" in r.stderr and "NoSuchMap" in r.stderr
    assert os.listdir(tmp_path) == ["fails.mlx"]
