"""MeshLab-style filter descriptions: one source for the dataclasses, CLI, MeshSet functions, .mlx, docs."""

import importlib.util
import inspect
import os
import subprocess
import sys
from dataclasses import MISSING, fields

import numpy as np
import pymeshlab
import pytest
import trimesh

from skelfilter.cli import parser as cli_parser
from skelfilter.errors import ParameterError
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.meshlab import descriptions, meshset, mlx, scripts
from skelfilter.meshlab.descriptions import ADD_SKELETON_NOISE, FILTERS, SKELETON_SALIENCY_DENOISE
from skelfilter.params import DenoiseParams, NoiseParams

ROOT = os.path.join(os.path.dirname(__file__), "..")
SCRIPTS = os.path.join(ROOT, "meshlab_scripts")
BASELINES = os.path.join(ROOT, "skelfilter", "evaluation", "comparison", "scripts")


def make_scripts():
    spec = importlib.util.spec_from_file_location("make_scripts", os.path.join(SCRIPTS, "make_scripts.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_descriptions_are_read_off_the_dataclasses():
    for description, cls in ((SKELETON_SALIENCY_DENOISE, DenoiseParams), (ADD_SKELETON_NOISE, NoiseParams)):
        assert description.params_class is cls
        assert [p.name for p in description.parameters] == [f.name for f in fields(cls)]
        for p, f in zip(description.parameters, fields(cls)):
            assert f.default is not MISSING and p.default == f.default
            assert p.description and p.tooltip == f.metadata["help"]
    d = {p.name: p for p in SKELETON_SALIENCY_DENOISE.parameters}
    assert (d["resolution"].rich_type, d["threshold"].rich_type, d["stages"].rich_type) == (
        "RichInt", "RichFloat", "RichEnum")
    assert d["stages"].choices == ("preset", "both", "foreground", "background", "auto")
    assert d["preset"].choices == ("default", "thesis", "thesis-tuned")
    assert (d["threshold"].measure, d["threshold_relative"].measure, d["k"].measure) == (
        "absolute", "relative", "")
    assert d["padding"].optional and d["padding"].meshlab_default == 0
    n = {p.name: p for p in ADD_SKELETON_NOISE.parameters}
    assert (n["dents"].rich_type, n["h"].rich_type, n["p"].rich_type) == ("RichBool", "RichInt", "RichFloat")
    assert descriptions.find("Skeleton Saliency Denoise") is descriptions.find("apply_skeleton_saliency_denoise") \
        is descriptions.find("denoise") is SKELETON_SALIENCY_DENOISE


@pytest.mark.parametrize("description", FILTERS, ids=lambda d: d.command)
def test_zero_stands_for_unset_without_ambiguity(description):
    for p in description.parameters:
        if not p.optional:
            continue
        assert p.to_python(0) is None and p.to_python(None) is None
        with pytest.raises(ParameterError):  # 0 is never a valid value of an optional parameter
            description.params_class(**{p.name: 0})


def test_values_are_type_checked():
    assert SKELETON_SALIENCY_DENOISE.make_params(threshold=12, padding=0).threshold == 12.0
    for bad in (dict(threshold="12"), dict(resolution=64.0), dict(resolution=True), dict(stages="all"),
                dict(no_such=1)):
        with pytest.raises(ParameterError):
            SKELETON_SALIENCY_DENOISE.make_params(**bad)
    with pytest.raises(ParameterError, match="dents takes a bool"):
        ADD_SKELETON_NOISE.make_params(dents=1)


def _flags(parser):
    return {a.dest for a in parser._actions if a.option_strings and a.dest not in ("help",)}


def test_cli_flags_and_meshset_signatures_come_from_the_descriptions():
    parser = cli_parser.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices
    export = next(a for a in sub["export-script"]._actions if a.dest == "filter").choices
    for d in FILTERS:
        names = {p.name for p in d.parameters}
        assert names <= _flags(sub[d.command])
        assert _flags(sub[d.command]) - names <= {"save_skeleton", "progress", "close", "points", "label", "iso",
                                                  "all_labels",
                                                  "spacing", "help_all", "preview"}
        assert _flags(export[d.command]) == names
        signature = inspect.signature(getattr(meshset, d.python_name))
        assert [(q.name, q.default) for q in list(signature.parameters.values())[1:]] == [
            (p.name, p.default) for p in d.parameters]
        assert d.name in getattr(meshset, d.python_name).__doc__


def test_export_then_read_gives_the_parameters_back(tmp_path):
    params = DenoiseParams(resolution=96, threshold_relative=0.05, stages="background", importance="estimate",
                           geodesic_cap=40.0, k=0.75)
    path = tmp_path / "d.mlx"
    scripts.export_script(path, SKELETON_SALIENCY_DENOISE, params)
    (name, values), = scripts.read_filter_script(path)
    assert name == "apply_skeleton_saliency_denoise" and DenoiseParams(**values) == params
    # the CLI writes the same file from the same flags
    r = subprocess.run([sys.executable, "-m", "skelfilter.cli", "export-script", "denoise",
                        tmp_path / "c.mlx", "--resolution", "96", "--threshold-relative", "0.05",
                        "--stages", "background", "--importance", "estimate", "--geodesic-cap", "40",
                        "--k", "0.75"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "c.mlx").read_text() == path.read_text()
    noise = NoiseParams(p=0.02, l=1, dents=True, seed=5)
    scripts.export_script(tmp_path / "n.mlx", ADD_SKELETON_NOISE, noise)
    (name, values), = scripts.read_filter_script(tmp_path / "n.mlx")
    assert name == "apply_skeleton_noise" and NoiseParams(**values) == noise


def test_docs_are_generated_from_the_descriptions():
    with open(os.path.join(ROOT, "docs", "filters.md"), encoding="utf-8") as f:
        assert f.read() == descriptions.markdown(), "docs/filters.md is stale: run `make docs`"
    for d in FILTERS:
        for p in d.parameters:
            assert f"| `{p.name}` | {p.rich_type}" in descriptions.markdown()


def test_filters_command_lists_ours_and_meshlabs():
    r = subprocess.run([sys.executable, "-m", "skelfilter.cli", "filters", "--meshlab"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    for d in FILTERS:
        assert descriptions.text(d) in r.stdout
    assert "apply_coord_taubin_smoothing (pymeshlab)\n  lambda_: float = 0.5\n  mu: float = -0.53" in r.stdout
    assert r.stdout.count("(pymeshlab)") == len(pymeshlab.filter_list())


def test_shipped_scripts_are_what_the_generator_writes(tmp_path):
    gen = make_scripts()
    written = [os.path.basename(p) for p in gen.make_scripts(str(tmp_path), str(tmp_path))]
    shipped_in = {name: folder for folder in (SCRIPTS, BASELINES) for name in os.listdir(folder)
                  if name.endswith(".mlx")}
    assert sorted(written) == sorted(shipped_in)
    for name in written:
        with open(os.path.join(shipped_in[name], name), "rb") as f:
            shipped = f.read()
        new = (tmp_path / name).read_bytes()
        if name in ("skeleton_denoise.mlx", "mixed_example.mlx"):
            assert shipped == new, name  # skelfilter's writer orders the attributes
        else:  # pymeshlab writes the attributes in a random order
            assert [(e.name, [p.attrs for p in e.params]) for e in mlx.parse(shipped, name)] == [
                (e.name, [p.attrs for p in e.params]) for e in mlx.parse(new, name)]
    assert gen.skeleton_denoise_text() == (tmp_path / "skeleton_denoise.mlx").read_text()
    names = [n for n, _ in scripts.read_filter_script(os.path.join(SCRIPTS, "mixed_example.mlx"))]
    assert names == ["meshing_remove_duplicate_vertices", "meshing_remove_unreferenced_vertices",
                     "apply_skeleton_saliency_denoise", "apply_coord_taubin_smoothing"]


def test_pymeshlab_loads_a_script_of_meshlab_filters_written_by_skelfilter(tmp_path):
    gen = make_scripts()
    path = tmp_path / "ours.mlx"
    path.write_text(mlx.script_text(gen._saved_filters(gen.MIXED_SMOOTHING)))
    box = trimesh.creation.icosphere(2)
    ms = pymeshlab.MeshSet()
    ms.add_mesh(meshset.to_pymeshlab(box))
    ms.load_filter_script(str(path))
    ms.apply_filter_script()
    direct = pymeshlab.MeshSet()
    direct.add_mesh(meshset.to_pymeshlab(box))
    direct.apply_coord_taubin_smoothing(stepsmoothnum=4)
    assert np.array_equal(ms.current_mesh().vertex_matrix(), direct.current_mesh().vertex_matrix())


def test_meshset_functions_add_a_layer_like_meshlab_filters():
    box = trimesh.creation.box((1.0, 1.2, 0.8))
    ms = pymeshlab.MeshSet()
    ms.add_mesh(meshset.to_pymeshlab(box))
    assert np.array_equal(meshset.to_trimesh(ms.current_mesh()).vertices, box.vertices)
    assert np.array_equal(meshset.to_trimesh(ms.current_mesh()).faces, box.faces)
    meshset.apply_skeleton_noise(ms, resolution=40, seed=2, l=1, p=0.01)
    noisy = mesh_pipeline.noisy_mesh(box, NoiseParams(resolution=40, seed=2, l=1, p=0.01))[0]
    assert (ms.mesh_number(), ms.current_mesh_id()) == (2, 1)
    assert np.array_equal(ms.current_mesh().vertex_matrix(), noisy.vertices)
    meshset.register()
    ms.apply_skeleton_saliency_denoise(resolution=40, padding=0, importance="euclidean")
    clean = mesh_pipeline.denoise_mesh(noisy, resolution=40, importance="euclidean")
    assert (ms.mesh_number(), ms.current_mesh_id()) == (3, 2)
    assert np.array_equal(ms.current_mesh().vertex_matrix(), clean.vertices)
    assert np.array_equal(ms.current_mesh().face_matrix(), clean.faces)
    assert np.array_equal(ms.mesh(0).vertex_matrix(), box.vertices)  # the input layer is kept
    with pytest.raises(ParameterError, match="no parameter 'treshold'"):
        meshset.apply_skeleton_saliency_denoise(ms, treshold=12)
    assert ms.mesh_number() == 3
