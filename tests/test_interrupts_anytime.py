"""Signals at random moments of whole runs, start-up included (issue: reliability round 2): SIGINT,
SIGTERM or SIGHUP, to the process or to its whole process group (Ctrl-C in a terminal), during
``denoise``, ``run-script``, ``compare`` and ``batch``. Every run ends with exit 0 (it had finished)
or 128 + the signal's number and exactly one line, leaves no temporary file or folder, no partial
output and no process.

The first moments of a run belong to the Python interpreter's own start-up, before any code of
skelfilter's runs (some 0.1 s: the interpreter and its site packages); a signal then takes its default
action, as for any Python program. The moments drawn start after it.
"""

import os
import random
import signal
import subprocess
import sys
import time

import pytest
import trimesh

from skelfilter.io import mesh_files
from skelfilter.mesh import pipeline as mesh_pipeline

WORDS = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated", signal.SIGHUP: "hung up"}
RUNS = 8  # per command
START_UP = 0.15  # seconds of the interpreter's own start-up, not drawn

SCRIPT = ('<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name="Taubin Smooth"/>\n'
          ' <filter name="Skeleton Saliency Denoise">\n'
          '  <Param name="resolution" type="RichInt" value="40"/>\n'
          '  <Param name="prune" type="RichEnum" value="2" enum_val0="preset" enum_val1="measured"'
          ' enum_val2="as-told" enum_cardinality="3"/>\n'
          '  <Param name="noise_height" type="RichFloat" value="4"/>\n </filter>\n'
          ' <filter name="Laplacian Smooth"/>\n</FilterScript>\n')
LAPLACIAN = """
[[method]]
name = "Laplacian"
kind = "meshlab"
script = "{laplacian}"
"""

# the command, and where its output goes
COMMANDS = {
    "denoise": (["denoise", "{noisy}", "{out}/out.ply", "--resolution", "48", "--prune", "as-told", "--noise-height",
                 "5"], "out.ply"),
    "run-script": (["run-script", "{script}", "{noisy}", "{out}/out.ply"], "out.ply"),
    "compare": (["compare", "{config}", "--out", "{out}/report"], "report"),
    "batch": (["batch", "{noisy}", "--out", "{out}/batch", "--workers", "1", "--resolution", "48"], "batch"),
}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("inputs")
    noisy, _, _ = mesh_pipeline.noisy_mesh(trimesh.creation.box((1.0, 0.8, 0.6)), resolution=48, seed=1)
    mesh_files.save_mesh(noisy, root / "noisy.ply")
    (root / "s.mlx").write_text(SCRIPT)
    laplacian = os.path.join(os.path.dirname(mesh_files.__file__), "..", "evaluation", "comparison", "scripts",
                             "laplacian_surface_preserving.mlx")
    tiny = os.path.join(os.path.dirname(__file__), "data", "tiny-comparison.toml")
    (root / "tiny.toml").write_text(open(tiny).read() + LAPLACIAN.format(laplacian=os.path.abspath(laplacian)))
    return {"noisy": root / "noisy.ply", "script": root / "s.mlx", "config": root / "tiny.toml"}


def _session_processes(session):
    """Processes still in the session ``session`` (the run was started as its leader)."""
    left = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[3]) == session and fields[0] != "Z":
            left.append(int(pid))
    return left


def _complete(kind, path):
    """An output that exists is whole: the mesh, the report, a batch's finished files."""
    if kind == "out.ply":
        return len(mesh_files.load_mesh(path).faces) > 0
    if kind == "report":
        return {"results.json", "report.html", "cube"} <= set(os.listdir(path))
    # a batch keeps the outputs it finished (a rerun skips them), and makes no empty folder
    names = os.listdir(path)
    return names and all(n.startswith("summary.") or len(mesh_files.load_mesh(path / n).faces) for n in names)


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_signal_at_any_moment_ends_in_one_line(inputs, tmp_path, command):
    args, output = COMMANDS[command]
    rng = random.Random(f"{command}-signals")
    start = time.time()  # a run undisturbed first: how long the moments are drawn over, on this machine
    whole = tmp_path / "whole"
    whole.mkdir()
    assert subprocess.run([sys.executable, "-m", "skelfilter.cli", *[a.format(out=whole, **inputs) for a in args],
                           "--quiet"], capture_output=True, timeout=600).returncode == 0
    seconds = time.time() - start - START_UP
    interrupted = 0
    for run in range(RUNS):
        sig = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)[run % 3]
        to_group = run % 2 == 1
        delay = START_UP + rng.random() * seconds * 0.9
        out, private_tmp = tmp_path / f"run{run}", tmp_path / f"tmp{run}"
        out.mkdir()
        private_tmp.mkdir()
        argv = [a.format(out=out, **inputs) for a in args]
        proc = subprocess.Popen([sys.executable, "-m", "skelfilter.cli", *argv, "--quiet"], stdout=subprocess.DEVNULL,
                                stderr=subprocess.PIPE, text=True, start_new_session=True,
                                env={**os.environ, "TMPDIR": str(private_tmp)})
        time.sleep(delay)
        try:
            (os.killpg if to_group else os.kill)(proc.pid, sig)
        except ProcessLookupError:
            pass
        stderr = proc.communicate(timeout=600)[1]
        what = f"{command} run {run}: {signal.Signals(sig).name} to the {'group' if to_group else 'process'} " \
               f"after {delay:.2f} s"
        lines = [line for line in stderr.splitlines() if line.strip()]
        interrupted += proc.returncode != 0
        if proc.returncode == 0:
            assert lines == [], (what, stderr)
        else:
            assert (proc.returncode, lines) == (128 + sig, [f"skelfilter: {WORDS[sig]}"]), (what, stderr)
        deadline = time.time() + 20
        while _session_processes(proc.pid) and time.time() < deadline:
            time.sleep(0.2)
        assert _session_processes(proc.pid) == [], (what, "processes left")
        assert os.listdir(private_tmp) == [], (what, os.listdir(private_tmp))
        assert not [n for n in os.listdir(out) if n.startswith(".")], (what, os.listdir(out))
        target = out / output
        assert proc.returncode != 0 or target.exists(), what
        assert not target.exists() or _complete(output, target), (what, "partial output")
    assert interrupted >= RUNS // 2, f"only {interrupted} of {RUNS} runs were still running when signalled"
