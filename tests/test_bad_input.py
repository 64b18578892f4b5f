"""Bad or extreme input through the CLI: one line ``skelfilter: error: …``, exit 2, the input unchanged
and nothing left behind (issue: reliability). More cases live in test_cli.py and test_run_script.py."""

import hashlib
import os
import subprocess
import sys

import pytest
import trimesh

SCRIPT = '<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name="Taubin Smooth"/>\n</FilterScript>\n'

# (arguments, a piece of the expected message); {in}, {out}, {dir}, {file}, {script} are filled in
CASES = [
    (["denoise", "{in}", "{dir}"], "unsupported format ''"),
    (["denoise", "{in}", "{out}", "--resolution", str(2**63)], "resolution must be an integer in [16, 4096]"),
    (["denoise", "{in}", "{out}", "--resolution", "8"], "resolution must be an integer in [16, 4096]"),
    (["denoise", "{in}", "{out}", "--threshold", "1e30"], "threshold must be a number in"),
    (["denoise", "{in}", "{out}", "--threshold", "nan"], "threshold must be a number in"),
    (["denoise", "{in}", "{out}", "--k", "nan"], "k must be a number in [0, 100]"),
    (["denoise", "{in}", "{out}", "--k", "inf"], "k must be a number in [0, 100]"),
    (["denoise", "{in}", "{out}", "--k", "-1"], "k must be a number in [0, 100]"),
    (["denoise", "{in}", "{out}", "--derivative-guard", "nan"], "derivative_guard must be a number"),
    (["denoise", "{in}", "{out}", "--minify-radius", "inf"], "minify_radius must be a number"),
    (["denoise", "{in}", "{out}", "--geodesic-cap", "-5"], "geodesic_cap must be a number"),
    (["denoise", "{in}", "{out}", "--padding", "1"], "padding must be an integer in [2, 4096]"),
    (["denoise", "{in}", "{out}", "--resolution", "abc"], "invalid int value"),
    (["denoise", "{in}", "{out}", "--output-mesh", "cube"], "invalid choice"),
    (["denoise", "{in}", "{out}", "--close", "--output-mesh", "input"], "--close contradicts"),
    (["denoise", "{in}"], "the following arguments are required"),
    (["denoise", "{in}", "{out}.xyz"], "unsupported format 'xyz'"),
    (["denoise", "{in}", "{in}"], "refusing to overwrite the input file"),
    (["noise", "{in}", "{out}", "--r", "nan"], "r must be a number in"),
    (["noise", "{in}", "{out}", "--r", "inf"], "r must be a number in"),
    (["noise", "{in}", "{out}", "--seed", "-1"], "seed must be an integer in"),
    (["noise", "{in}", "{out}", "--l", "1000000000"], "l must be an integer in [1, 100000]"),
    (["noise", "{in}", "{out}", "--p", "2"], "p must be a number in [0, 1]"),
    (["noise", "{in}", "{out}", "--h", "-3"], "h must be an integer in"),
    (["run-script", "{script}", "{in}", "{out}", "--timeout", "nan"], "must be a number of seconds"),
    (["run-script", "{script}", "{in}", "{out}", "--timeout", "0"], "must be a number of seconds"),
    (["run-script", "{script}", "{in}", "{out}", "--timeout", "-1"], "must be a number of seconds"),
    (["compare", "{dir}", "--out", "{dir}/report"], "no such configuration file"),
    (["compare", "--out", "{file}"], "exists and is not a folder"),
    (["frobnicate"], "invalid choice"),
]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("bad")
    mesh = root / "cube.ply"
    trimesh.creation.box().export(mesh)
    script = root / "s.mlx"
    script.write_text(SCRIPT)
    (root / "adir").mkdir()
    (root / "afile").write_text("x")
    return root


def digest(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


@pytest.mark.parametrize("args, message", CASES, ids=[" ".join(a[:1] + a[3:]) or a[0] for a, _ in CASES])
def test_bad_input_gives_one_line_and_exit_2(files, tmp_path, args, message):
    names = {"in": files / "cube.ply", "out": tmp_path / "out.ply", "dir": files / "adir", "file": files / "afile",
             "script": files / "s.mlx"}
    argv = [a.format(**{k: str(v) for k, v in names.items()}) for a in args]
    before = {p: digest(files / p) for p in ("cube.ply", "s.mlx", "afile")}
    r = subprocess.run([sys.executable, "-m", "skelfilter.cli", *argv], capture_output=True, text=True, timeout=300)
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith("skelfilter: error:"), r.stderr
    assert message in lines[0]
    assert {p: digest(files / p) for p in before} == before
    assert os.listdir(tmp_path) == [] and os.listdir(files / "adir") == []


@pytest.mark.parametrize("extra, message", [
    (["--save-skeleton", "{out}"], "refusing to overwrite the output file"),
    (["--save-skeleton", "{in}"], "refusing to overwrite the input file"),
    (["--save-skeleton", "{tmp}/missing/s.ply"], "output folder does not exist"),
    (["--save-skeleton", "{tmp}/s.obj"], "unsupported format 'obj' (use ply)"),
])
def test_output_paths_are_checked_before_computing(files, tmp_path, extra, message):
    names = {"in": str(files / "cube.ply"), "out": str(tmp_path / "out.ply"), "tmp": str(tmp_path)}
    argv = ["denoise", names["in"], names["out"], "--output-mesh", "closed", "--resolution", "32"]
    r = subprocess.run([sys.executable, "-m", "skelfilter.cli", *argv, *[a.format(**names) for a in extra]],
                       capture_output=True, text=True, timeout=300)
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert r.returncode == 2 and len(lines) == 1 and message in lines[0], r.stderr
    assert os.listdir(tmp_path) == []
