"""Smoke test of the benchmark at one small size (no timing assertions)."""

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from conftest import cube_with_a_bump_and_a_dent

from benchmarks import oracle

ROOT = os.path.join(os.path.dirname(__file__), "..")


def test_same_outputs_saves_a_corpus_and_names_what_differs(tmp_path, capsys):
    from benchmarks import same_outputs

    saved = tmp_path / "before.npz"
    same_outputs.save(str(saved), ["volumes"])
    arrays = dict(np.load(saved))
    assert {"volumes/volume-fandisk/mask", "volumes/volume-fandisk/field", "volumes/label-map/1.v"} <= set(arrays)
    assert same_outputs.main(["compare", str(saved), str(saved)]) == 0
    arrays["volumes/volume-fandisk/field"] = arrays["volumes/volume-fandisk/field"].copy()
    arrays["volumes/volume-fandisk/field"].flat[0] += 1e-3
    del arrays["volumes/label-map/1.v"]
    changed = tmp_path / "after.npz"
    np.savez(changed, **arrays)
    differ = same_outputs.compare(str(saved), str(changed))
    assert len(differ) == 2
    assert differ[0].startswith("volumes/label-map/1.v: only in") and "1 of" in differ[1]
    assert same_outputs.main(["compare", str(saved), str(changed)]) == 1
    assert "2 arrays differ" in capsys.readouterr().out


def test_thread_scaling_prints_every_step_and_its_parallel_share():
    from benchmarks import thread_scaling

    assert thread_scaling.parallel_share(4.0, 2.0, 2) == 1.0 and thread_scaling.parallel_share(4.0, 4.0, 2) == 0.0
    assert thread_scaling.parallel_share(4.0, 3.0, 2) == pytest.approx(0.5)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.path.abspath(ROOT), os.environ.get("PYTHONPATH", "")]))
    done = subprocess.run([sys.executable, "-m", "benchmarks.thread_scaling", "--size", "40",
                           "--threads", "1", "2"], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    rows = {line[:40].strip(): line[40:].split() for line in done.stdout.splitlines()[2:]}
    assert {"foreground/importance", "total, mesh file to mesh file"} <= set(rows)
    for cells in rows.values():
        assert len(cells) == 5 and cells[2].endswith("%")


def test_benchmark_writes_every_figure(tmp_path):
    out = tmp_path / "bench.json"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.path.abspath(ROOT), os.environ.get("PYTHONPATH", "")]))
    done = subprocess.run([sys.executable, "-m", "benchmarks.bench_pipeline",
                           "--sizes", "48", "56", "--volume-size", "48", "--repeat", "1", "--json", str(out)],
                          env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "ratio total / EDT" in done.stdout
    data = json.loads(out.read_text())
    assert data["machine"]["cores"] >= 1
    small, large = data["results"]
    for r in (small, large):
        assert r["voxels"] == r["grid"][0] * r["grid"][1] * r["grid"][2]
        assert 0 < r["edt_with_indices_s"] and 0 < r["total_s"] >= max(r["steps_s"].values())
        assert r["edt_ratio"] == r["total_s"] / r["edt_with_indices_s"]
        assert r["peak_rss_mib"] > 0 and r["bytes_per_voxel"] > 0
        assert {"voxelize", "solid check", "foreground/importance", "foreground/reconstruction",
                "foreground/noise estimate", "foreground/features kept"} <= set(r["steps_s"])
        # specks and needles are taken off only where noise was found (else the input passes through)
        assert ("needles" in r["steps_s"]) == ("input surface" in r["steps_s"])
        # the output the default chose: a new closed mesh, or the input mesh (smoothed where it has fine
        # noise; at 48 voxels the thesis' noise, 5 voxels high, is no longer told from relief)
        assert {"input surface", "marching cubes"} <= set(r["steps_s"]) or "fine noise" in r["steps_s"]
        assert set(r["steps_peak_mib"]) == set(r["steps_s"])
        assert set(r["stages"]) == {"foreground"}  # the default preset
        for stage in r["stages"]:
            s = r["stages"][stage]
            assert s["skeleton_voxels"] > s["kept"] > 0
            assert s["astar_searches"] > 0 and s["astar_expansions_mean"] >= 1
    assert large["voxels"] > small["voxels"]
    assert set(data["exponents"]) == set(small["steps_s"]) | {"total", "edt_with_indices"}
    volume = data["volume"]
    assert volume["size"] == 48 and volume["voxels"] >= 48 ** 3
    assert volume["edt_ratio"] == volume["total_s"] / volume["edt_with_indices_s"] > 0
    runs = data["commands"]
    # a fresh process does at least what importing the package does
    assert min(runs["clean_s"], runs["everyday_s"], runs["read_write_s"]) > runs["import_s"] > 0
    assert runs["help_s"] > 0
    # the 256 ratio, the exponents and the 512 memory need those sizes: not checked at 48 and 56
    assert set(data["targets"]) == {"volume total / EDT at 48", "clean bunny, seconds over read+write + 1 s",
                                    "everyday scan (s)", "import skelfilter (s)", "skelfilter --help (s)"}
    for value, limit, met in data["targets"].values():
        assert met == (value <= limit)


# each kind of table: the geodesic estimate, the skeleton errors, the reconstruction errors; the cube's
# first printed figure of the thesis
@pytest.mark.parametrize("table, thesis_figure", [("7.1", 0.1169), ("4.1", 0.2506), ("6.2", 0.0008)])
def test_thesis_tables_print_both_columns(tmp_path, table, thesis_figure):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.path.abspath(ROOT), os.environ.get("PYTHONPATH", "")]))
    done = subprocess.run([sys.executable, "-m", "benchmarks.thesis_tables", table,
                           "--resolution", "32", "--out", str(tmp_path)], env=env, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    rows = [line for line in done.stdout.splitlines() if line.startswith("| cube")]
    assert len(rows) == 1
    ours, thesis = (float(x) for x in re.search(r"([0-9.]+)(?: / [0-9.]+)? \\\| ([0-9.]+)", rows[0]).groups())
    assert 0 <= ours <= 1 and thesis == thesis_figure  # ours beside the thesis' printed figure


def test_the_ball_oracle_removes_a_bump_and_fills_a_dent():
    clean, noisy = cube_with_a_bump_and_a_dent()
    out, (centres, radii, clean_radii, noise) = oracle.oracle(noisy, clean)
    assert not (out & ~clean)[14:18, 14:18, 32:35].any()
    assert out[22:26, 22:26, 29:32].all()
    assert (out ^ clean).sum() < 0.01 * clean.sum()
    # the balls labelled noise are those standing more than a voxel beyond the clean shape
    assert noise.any() and (noise == (radii - clean_radii > oracle.PROTRUSION)).all()


def test_the_owned_oracle_removes_a_bump_and_fills_a_dent_without_gaps():
    clean, noisy = cube_with_a_bump_and_a_dent()
    out = oracle.owned_oracle(noisy, clean)
    assert not out[15:17, 15:17, 33:35].any() and out[23:25, 23:25, 29:32].all()
    # no coverage gaps: what stays wrong is one voxel at the rims (of the 96 the noise changed)
    assert (out ^ clean).sum() <= (noisy ^ clean).sum() / 6


def test_procedural_shapes_are_repeatable_solids_with_thin_parts():
    """The made-up training shapes: one seed, one shape; watertight; rods and plates thinner than
    the benchmark's thin-part ball (8 voxels across at 160) make a good share of their voxels."""
    from benchmarks import shapes
    from skelfilter.evaluation.metrics import thin_parts
    from skelfilter.mesh.voxelize import voxelize

    first, again, other = shapes.procedural(3), shapes.procedural(3), shapes.procedural(4)
    assert np.array_equal(first.vertices, again.vertices) and not np.array_equal(first.vertices, other.vertices)
    assert first.is_watertight and first.is_volume
    grid = voxelize(shapes.load("procedural-3"), resolution=160)[0]
    assert 0.05 < thin_parts(grid, 4.0).sum() / grid.sum() < 0.9
