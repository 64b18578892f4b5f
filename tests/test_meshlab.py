"""MeshLab baseline scripts (skelfilter/evaluation/comparison/scripts/*.mlx) and the crash-safe pymeshlab runner."""

import os

import numpy as np
import pymeshlab
import pytest
import trimesh

from skelfilter.errors import InputError, SkelfilterError
from skelfilter.meshlab.scripts import read_filter_script, run_filter_script

SCRIPTS = os.path.join(os.path.dirname(__file__), "..", "skelfilter", "evaluation", "comparison", "scripts")


def script(name):
    return os.path.join(SCRIPTS, name)


@pytest.fixture(scope="module")
def noisy_box():
    box = trimesh.creation.box(extents=(10, 10, 10)).subdivide().subdivide().subdivide()
    rng = np.random.default_rng(7)
    vertices = box.vertices + rng.normal(0.0, 0.15, box.vertices.shape)
    return trimesh.Trimesh(vertices=vertices, faces=box.faces, process=False)


def test_scripts_hold_the_thesis_parameters():
    (name, p), = read_filter_script(script("laplacian_surface_preserving.mlx"))
    assert name == "apply_coord_laplacian_smoothing_surface_preserving"
    assert p["angledeg"] == 60 and p["iterations"] == 50
    (name, p), = read_filter_script(script("two_step.mlx"))
    assert name == "apply_coord_two_steps_smoothing"
    assert (p["stepsmoothnum"], p["normalthr"], p["stepnormalnum"], p["stepfitnum"]) == (40, 60, 20, 20)
    for file, filt in (("mls_apss.mlx", "compute_mls_projection_apss"),
                       ("rimls.mlx", "compute_mls_projection_rimls")):
        (name, p), = read_filter_script(script(file))
        assert name == filt and p["filterscale"] == 15
        assert p["maxsubdivisions"] == 0 and p["thangleindegree"] == 2  # defaults kept
    (name, p), = read_filter_script(script("taubin.mlx"))
    assert name == "apply_coord_taubin_smoothing"
    assert (p["lambda_"], p["mu"], p["stepsmoothnum"]) == (0.5, -0.53, 10)


def _direct(mesh, filt, params):
    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=np.asarray(mesh.vertices, dtype=np.float64),
                               face_matrix=np.asarray(mesh.faces, dtype=np.int32)))
    getattr(ms, filt)(**params)
    return ms.current_mesh().vertex_matrix(), ms.current_mesh().face_matrix()


@pytest.mark.parametrize("file", ["laplacian_surface_preserving.mlx", "two_step.mlx"])
def test_runner_matches_pymeshlab_in_process(noisy_box, file):
    (filt, params), = read_filter_script(script(file))
    expected_v, expected_f = _direct(noisy_box, filt, params)
    out = run_filter_script(noisy_box, script(file))
    assert out.vertices.shape == expected_v.shape
    assert np.allclose(out.vertices, expected_v, atol=1e-6, rtol=0)
    assert np.array_equal(out.faces, expected_f)
    assert not np.allclose(out.vertices, noisy_box.vertices)  # the filter did something


def test_apss_runs_with_the_workaround(noisy_box):
    out = run_filter_script(noisy_box, script("mls_apss.mlx"))
    assert len(out.vertices) == len(noisy_box.vertices)
    assert np.isfinite(out.vertices).all() and len(out.faces) == len(noisy_box.faces)


def test_child_crash_is_reported(noisy_box, meshlab_fault):
    meshlab_fault("abort")
    with pytest.raises(SkelfilterError, match="(?i)abort"):
        run_filter_script(noisy_box, script("taubin.mlx"))


TWO_FILTERS = ('<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name="Taubin Smooth"/>\n'
               ' <filter name="Laplacian Smooth"/>\n</FilterScript>\n')


@pytest.mark.parametrize("hook, expected", [
    ("abort@1", r"two.mlx:4: filter 'Laplacian Smooth' \(pymeshlab's apply_coord_laplacian_smoothing\) "
                r"crashed: .*signal 6"),
    ("sleep@1", r"two.mlx:4: filter 'Laplacian Smooth' .* did not finish within 2 s"),
    ("abort", r"two.mlx:3: filter 'Taubin Smooth' \(pymeshlab's apply_coord_taubin_smoothing\) crashed"),
])
def test_the_filter_that_crashed_or_hung_is_named(noisy_box, meshlab_fault, tmp_path, hook, expected):
    (tmp_path / "two.mlx").write_text(TWO_FILTERS)
    meshlab_fault(hook)
    with pytest.raises(SkelfilterError, match=expected):
        run_filter_script(noisy_box, str(tmp_path / "two.mlx"), timeout=2)


def test_child_timeout_is_reported(noisy_box, meshlab_fault):
    meshlab_fault("sleep")
    with pytest.raises(SkelfilterError, match="did not finish within 1 s"):
        run_filter_script(noisy_box, script("taubin.mlx"), timeout=1)


def test_pymeshlab_error_is_reported(noisy_box, tmp_path):
    # a well-formed script pymeshlab refuses only when it runs: an enum label it does not know
    bad = tmp_path / "bad.mlx"
    bad.write_text('<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name="Taubin Smooth"/>\n'
                   ' <filter name="Colorize by vertex Quality">\n'
                   '  <Param name="colorMap" value="0" enum_val0="NoSuchMap" type="RichEnum"/>\n'
                   ' </filter>\n</FilterScript>\n')
    with pytest.raises(SkelfilterError, match=r"bad.mlx:4: filter 'Colorize by vertex Quality': "
                                              r"pymeshlab's compute_color_from_scalar_per_vertex failed.*NoSuchMap"):
        run_filter_script(noisy_box, bad)


@pytest.mark.parametrize("text, message", [
    ("<FilterScript><filter name='Taubin Smooth'>", "malformed"),
    ('<?xml version="1.0"?>\n<!DOCTYPE lolz [\n <!ENTITY lol "lol">\n'
     ' <!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;">\n'
     ' <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;">\n]>\n'
     '<FilterScript><filter name="&lol3;"/></FilterScript>', "ENTITY"),
    ('<!DOCTYPE FilterScript SYSTEM "file:///etc/passwd">\n<FilterScript/>', "DOCTYPE"),
    ('<FilterScript><filter name="No Such Filter At All"/></FilterScript>', "not available"),
    ('<FilterScript><filter name="Taubin Smooth"><Param name="mu" value="x" type="RichFloat"/>'
     '</filter></FilterScript>', "not a number"),
    ("<Other/>", "FilterScript"),
    # values pymeshlab would take and misread, or fail on: a percentage past its range, a colour of 1e20,
    # a bounded float past its bounds
    ('<FilterScript><filter name="Random Vertex Displacement"><Param name="displacement" value="5" min="0" max="2"'
     ' type="RichAbsPerc"/></filter></FilterScript>', r"outside its range \[0, 2\]"),
    ('<FilterScript><filter name="Vertex Color White Balance"><Param name="color" r="1e20" g="0" b="0" a="255"'
     ' type="RichColor"/></filter></FilterScript>', r"integers in \[0, 255\]"),
    ('<FilterScript><filter name="Vertex Color Thresholding"><Param name="threshold" value="300" min="0" max="255"'
     ' type="RichDynamicFloat"/></filter></FilterScript>', r"outside pymeshlab's range \[0, 255\]"),
])
def test_bad_scripts_are_refused(tmp_path, text, message):
    path = tmp_path / "bad.mlx"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        read_filter_script(path)


def test_oversized_script_is_refused(tmp_path, noisy_box):
    path = tmp_path / "big.mlx"
    with open(script("taubin.mlx"), "rb") as f:
        head = f.read()
    path.write_bytes(head + b"<!--" + b" " * (1 << 20) + b"-->")
    with pytest.raises(InputError, match="1 MiB"):
        read_filter_script(path)
    with pytest.raises(InputError, match="1 MiB"):
        run_filter_script(noisy_box, path)


def test_the_denoise_description_says_what_the_default_does():
    from skelfilter.meshlab.descriptions import SKELETON_SALIENCY_DENOISE as denoise
    from skelfilter.params import DenoiseParams

    # a clean open bowl: the default gives back the user's own mesh, open as it was, not a new
    # watertight one
    sphere = trimesh.creation.icosphere(4)
    bowl = sphere.submesh([np.flatnonzero(sphere.triangles_center[:, 2] < 0.3)], append=True)
    out = denoise.apply(bowl, DenoiseParams())
    assert np.array_equal(out.faces, bowl.faces) and not out.is_watertight
    assert "watertight layer" not in denoise.description
    assert "comes back as it was" in denoise.description and "fine pass" in denoise.description
    assert "new closed mesh" in denoise.description  # what the voxel stage gives
