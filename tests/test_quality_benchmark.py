"""Smoke test of the quality benchmark (benchmarks/quality.py) at a small resolution, and its genus helper."""

import json

import numpy as np
import pytest
import trimesh

from benchmarks import quality, shapes
from skelfilter.evaluation import metrics
from skelfilter.mesh.voxelize import voxelize
from skelfilter.params import DenoiseParams


@pytest.mark.parametrize("mesh, expected", [
    (trimesh.creation.torus(1.0, 0.4), 1),
    (trimesh.creation.icosphere(), 0),
    (shapes.block_with_holes_and_boss(), 2),
    (shapes.l_bracket(), 1),
])
def test_genus_from_the_mesh_and_from_voxels(mesh, expected):
    assert metrics.genus(mesh) == {"genus": expected, "components": 1, "from": "mesh"}
    assert metrics.voxel_genus(voxelize(mesh, 64, 2)[0]) == {"genus": expected, "components": 1, "from": "voxels"}


def test_genus_of_a_non_manifold_mesh_comes_from_voxels():
    a = trimesh.creation.box((1.0, 1.0, 1.0))
    b = a.copy()
    b.apply_translation((1.0, 1.0, 0.0))  # the two cubes share an edge: four faces on it
    pair = trimesh.util.concatenate([a, b])
    assert metrics.closed_manifold_genus(pair) is None
    assert metrics.genus(pair)["from"] == "voxels"
    # Separate closed surfaces add up: a torus and a sphere apart have genus 1 in 2 surfaces.
    torus, ball = trimesh.creation.torus(1.0, 0.4), trimesh.creation.icosphere()
    ball.apply_translation((5.0, 0.0, 0.0))
    assert metrics.genus(trimesh.util.concatenate([torus, ball])) == {"genus": 1, "components": 2, "from": "mesh"}


def test_built_shapes_are_watertight_with_their_known_genus():
    for name in ("block", "pocket-plate", "u-channel", "l-bracket"):
        mesh = shapes.load(name)
        assert mesh.is_watertight and mesh.is_winding_consistent, name
        assert max(mesh.extents) == pytest.approx(1.0)
        assert metrics.genus(mesh)["genus"] == shapes.SHAPES[name].genus, name


def test_variant_text():
    label, params = quality.parse_variant("t12:threshold=12,stages=foreground,k=0.8", 160)
    assert label == "t12"
    assert params == DenoiseParams(resolution=160, threshold=12, stages="foreground", k=0.8)
    assert quality.parse_variant("big:resolution=256", 160)[1].resolution == 256
    with pytest.raises(ValueError):
        quality.parse_variant("bad:no_such_field=1", 160)


def test_quality_benchmark_smoke(tmp_path):
    out = tmp_path / "out"
    results = quality.main(["--resolution", "64", "--shapes", "cube,l-bracket", "--kinds", "stripes", "--seeds", "1",
                            "--variant", "default:noise_height=7,prune=as-told", "--rivals", "taubin", "--jobs", "1",
                            "--clean-pass",
                            "--out", str(out), "--cache", str(tmp_path / "cache")])
    saved = json.loads((out / "results.json").read_text())
    assert [c["name"] for c in saved["cases"]] == ["cube stripes s1", "l-bracket stripes s1"]
    assert [c["split"] for c in saved["cases"]] == ["tuning", "held-out"]
    for case in saved["cases"]:
        assert set(case["methods"]) == {"noisy", "default", "taubin"}
        for name, entry in case["methods"].items():
            assert entry["error"] is None, name
            for key in ("noise_left", "bumps_left", "clean_lost", "new_material", "chamfer", "hausdorff_95",
                        "normal_error_deg", "sharp_edge_mean", "genus", "voxel_genus", "seconds"):
                assert np.isfinite(entry[key]), (name, key)
            assert np.isnan(entry["dents_left"])
        assert case["methods"]["noisy"]["noise_left"] == 1.0
        assert case["methods"]["default"]["noise_left"] < 1.0
    assert saved["shapes"]["l-bracket"]["genus"] == 1 and saved["shapes"]["cube"]["genus"] == 0
    assert set(saved["clean_pass"]["default"]) == {"cube", "l-bracket"}
    assert {j["status"] for j in results["acceptance"]["tuning"]} <= {"met", "NOT met", "n/a"}

    table = (out / "table.md").read_text()
    tuning = table[table.index("## tuning split"):table.index("## held-out split")]
    held_out = table[table.index("## held-out split"):table.index("## Clean pass")]
    assert "cube stripes s1" in tuning and "l-bracket" not in tuning
    assert "l-bracket stripes s1" in held_out and "cube" not in held_out
    assert "### Acceptance of `default`" in tuning and "### Summary" in held_out
    assert (out / "sheet.png").stat().st_size > 0

    # A second run takes the rival from the cache: same numbers, no rerun.
    again = quality.main(["--resolution", "64", "--shapes", "cube", "--kinds", "stripes", "--seeds", "1",
                          "--variant", "default:noise_height=7,prune=as-told", "--rivals", "taubin", "--jobs", "1",
                          "--cached-rivals",
                          "--no-pictures", "--out", str(tmp_path / "again"), "--cache", str(tmp_path / "cache")])
    assert again["cases"][0]["methods"]["taubin"] == saved["cases"][0]["methods"]["taubin"]


def test_the_oracle_row_removes_the_noise_it_labels_and_has_the_clean_genus(tmp_path):
    out = tmp_path / "out"
    results = quality.main(["--resolution", "64", "--shapes", "cube", "--kinds", "bumps-dents", "--seeds", "1",
                            "--variant", "default", "--rivals", "none", "--oracle", "--no-pictures", "--jobs", "1",
                            "--out", str(out), "--cache", str(tmp_path / "cache")])
    methods = results["cases"][0]["methods"]
    oracle, noisy = methods["oracle"], methods["noisy"]
    assert oracle["error"] is None and results["settings"]["oracle"]
    # measured: 0.7 % of the bumps and 1.0 % of the dents left, error 0.028, Chamfer 0.16 against 1.73
    assert oracle["bumps_left"] < 0.05 and oracle["dents_left"] < 0.05 and oracle["clean_lost"] < 0.01
    assert oracle["error_ratio"] < 0.1 and oracle["chamfer"] < 0.2 * noisy["chamfer"]
    # the seam smoothing takes the threads that made handles: the clean cube's genus, 0 (the input's 589)
    assert oracle["genus"] == 0 < noisy["genus"]
    assert "| oracle |" in (out / "table.md").read_text()
