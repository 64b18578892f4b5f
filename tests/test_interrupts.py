"""Interrupts: SIGINT or SIGTERM in any pipeline step, or while a MeshLab child runs, end with one
line, exit 130 (143 for SIGTERM), no output, no temporary file or folder, no child left running."""

import glob
import hashlib
import os
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np
import pytest
import trimesh

import harness
from skelfilter.mesh import pipeline as mesh_pipeline

HARNESS = harness.__file__

# every step of a run, with the output mesh that makes it run
STEPS = [(step, "auto") for step in (
    "voxelize", "solid check", "foreground/distance transform", "foreground/skeleton",
    "foreground/importance", "foreground/derivative measure", "foreground/pruning", "foreground/EDT filter",
    "foreground/reconstruction", "foreground/noise estimate", "foreground/features kept", "specks", "needles")]
STEPS += [("input surface", "closed"), ("smooth surface", "closed"), ("vertices moved", "input"),
          ("fine pass", "input")]


def digest(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


@pytest.fixture(scope="module")
def noisy_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("in") / "noisy.ply"
    noisy, _, _ = mesh_pipeline.noisy_mesh(trimesh.creation.box((1.0, 0.8, 0.6)), resolution=48, seed=1)
    noisy.export(path)
    return path


def start(args, fault, argument):
    """The CLI with ``args``, run by `harness` with a fault injected."""
    return subprocess.Popen([sys.executable, HARNESS, fault, argument, "--", *map(str, args)],
                            env=harness.with_harness_path(dict(os.environ)), stderr=subprocess.PIPE,
                            stdout=subprocess.DEVNULL, text=True)


def wait_for(proc, text, timeout=120):
    """Read stderr lines until one contains ``text``; returns the lines read."""
    lines, deadline = [], time.time() + timeout
    while time.time() < deadline:
        line = proc.stderr.readline()
        if not line:
            break
        lines.append(line)
        if text in line:
            return lines
    raise AssertionError(f"never saw {text!r}: {''.join(lines)[-2000:]}")


def finish(proc, lines):
    rest = proc.communicate(timeout=120)[1]
    errors = [line for line in (lines + rest.splitlines()) if line.startswith("skelfilter:")]
    return proc.returncode, errors


@pytest.mark.parametrize("step, output_mesh", STEPS)
def test_an_interrupt_in_any_step_ends_cleanly(noisy_file, tmp_path, step, output_mesh):
    before = digest(noisy_file)
    out = tmp_path / "out.ply"
    for sig, code, word in ((signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")):
        # at 48 voxels the noise (5 voxels high) is not told from relief: its height is given
        proc = start(["denoise", noisy_file, out, "--resolution", "48", "--prune", "as-told", "--noise-height", "5",
                      "--output-mesh", output_mesh],
                     "pause", step)
        lines = wait_for(proc, f"paused in {step}")
        proc.send_signal(sig)
        returncode, errors = finish(proc, lines)
        assert (returncode, errors) == (code, [f"skelfilter: {word}\n".strip()]), (step, errors)
        assert not out.exists() and not os.listdir(tmp_path)
    assert digest(noisy_file) == before


def test_an_interrupt_while_the_roughness_is_measured_ends_cleanly(tmp_path):
    """A mesh not made of voxels, no flags: the route is measured (the roughness step) first."""
    path = tmp_path / "in" / "sphere.ply"
    path.parent.mkdir()
    sphere = trimesh.creation.icosphere(4)
    offset = np.random.default_rng(0).normal(0.0, 0.01, len(sphere.vertices))
    trimesh.Trimesh(sphere.vertices + sphere.vertex_normals * offset[:, None], sphere.faces).export(path)
    before = digest(path)
    out = tmp_path / "out" / "out.ply"
    out.parent.mkdir()
    proc = start(["denoise", path, out], "pause", "roughness")
    lines = wait_for(proc, "paused in roughness")
    proc.send_signal(signal.SIGINT)
    assert finish(proc, lines) == (130, ["skelfilter: interrupted"])
    assert not out.exists() and not os.listdir(out.parent) and digest(path) == before


def _children(pid):
    try:
        return [int(c) for c in open(f"/proc/{pid}/task/{pid}/children").read().split()]
    except OSError:
        return []


def _gone(pid, timeout=10.0):
    deadline = time.time() + timeout
    while time.time() < deadline:
        try:
            state = open(f"/proc/{pid}/stat").read().split(")")[-1].split()[0]
        except OSError:
            return True
        if state == "Z":
            return True
        time.sleep(0.1)
    return False


@pytest.mark.parametrize("sig, code, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated"),
                                             (signal.SIGKILL, -9, None)])
def test_a_meshlab_child_dies_with_its_parent(tmp_path, sig, code, word):
    mesh = tmp_path / "cube.ply"
    trimesh.creation.box().export(mesh)
    script = tmp_path / "s.mlx"
    script.write_text('<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name="Taubin Smooth"/>\n</FilterScript>\n')
    folders = set(glob.glob(os.path.join(tempfile.gettempdir(), "skelfilter-meshlab-*")))
    proc = start(["run-script", script, mesh, tmp_path / "out.ply"], "meshlab", "sleep")
    deadline = time.time() + 60
    while not _children(proc.pid) and time.time() < deadline:
        time.sleep(0.1)
    time.sleep(1.0)
    children = _children(proc.pid)
    assert children
    proc.send_signal(sig)
    returncode, errors = finish(proc, [])
    assert returncode == code
    if word:
        assert errors == [f"skelfilter: {word}"]
        assert set(glob.glob(os.path.join(tempfile.gettempdir(), "skelfilter-meshlab-*"))) == folders
    assert all(_gone(c) for c in children)
    assert not (tmp_path / "out.ply").exists()


def test_an_interrupt_inside_a_library_import_acts_once_it_is_loaded(tmp_path):
    """A compiled library interrupted half loaded spoiled the exit (open3d: exit 1 after "interrupted");
    `extras.load` holds the signal until the import ends, then it acts."""
    (tmp_path / "signalled_while_loading.py").write_text(
        "import os, signal\nos.kill(os.getpid(), signal.SIGINT)\nloaded = True\n")
    code = ("import sys\nfrom skelfilter.runtime import extras, signals\nsignals.install_handlers()\n"
            "try:\n    extras.load('signalled_while_loading')\nexcept signals.Interrupted:\n"
            "    print(sys.modules['signalled_while_loading'].loaded)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"})
    assert (proc.returncode, proc.stdout) == (0, "True\n"), proc.stderr


def test_a_signal_held_in_a_long_step_acts_at_its_next_checkpoint():
    """A SIGTERM during a filter's iterations (a fine pass on millions of faces held one for minutes)
    acts at the next iteration, not when the whole step ends; outside a held block nothing happens."""
    code = ("import os, signal\nfrom skelfilter.runtime import signals\nsignals.install_handlers()\n"
            "signals.checkpoint()\nreached = []\n"
            "try:\n    with signals.deferred():\n        signals.checkpoint()\n"
            "        os.kill(os.getpid(), signal.SIGTERM)\n        reached.append('sent')\n"
            "        signals.checkpoint()\n        reached.append('after the checkpoint')\n"
            "except signals.Interrupted as exc:\n    print(reached, exc.word, signal.SIGTERM in signal.pthread_sigmask("
            "signal.SIG_BLOCK, []))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert (proc.returncode, proc.stdout) == (0, "['sent'] terminated True\n"), proc.stderr


def test_nothing_follows_the_error_line_while_the_interpreter_shuts_down(tmp_path):
    # as a compiled library's finalizer of an object an interrupt left half made prints at exit
    late = ("import atexit, sys\n"
            "atexit.register(lambda: print('Exception ignored in: finalizer', file=sys.stderr))\n"
            "from skelfilter.cli import main\n"
            f"sys.exit(main(['denoise', {str(tmp_path / 'missing.ply')!r}, {str(tmp_path / 'out.ply')!r}]))\n")
    run = subprocess.run([sys.executable, "-c", late], capture_output=True, text=True, timeout=120)
    assert run.returncode == 2
    lines = run.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("skelfilter: error: ") and "missing.ply" in lines[0], run.stderr


def test_a_signal_while_a_kernel_compiles_acts_once_it_is_ready():
    """numba compiles a kernel, or loads it from its cache, on its first call, and LLVM calls back into
    Python meanwhile: an interrupt raised inside such a callback crashed ``compare`` (segmentation
    fault, no line). `compiled.njit` holds it until the kernel is ready; then the call raises it."""
    code = ("import os, signal\nfrom numba.core import event\nfrom skelfilter.runtime import signals\n"
            "from skelfilter.runtime.compiled import njit\nsignals.install_handlers()\nsent = []\n"
            "class SignalOnce(event.Listener):\n    def on_start(self, ev):\n        if not sent:\n"
            "            sent.append(1)\n            os.kill(os.getpid(), signal.SIGTERM)\n"
            "    def on_end(self, ev):\n        pass\n"
            "@njit()\ndef plus_one(x):\n    return x + 1\n"
            "try:\n    with event.install_listener('numba:compiler_lock', SignalOnce()):\n        plus_one(3)\n"
            "except signals.Interrupted as exc:\n    print(exc.word, len(plus_one.overloads), plus_one(3), "
            "signal.SIGTERM in signal.pthread_sigmask(signal.SIG_BLOCK, []))\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert (proc.returncode, proc.stdout, proc.stderr) == (0, "terminated 1 4 True\n", "")


LIBRARY_RUNS = r'''
import sys
import trimesh
from skelfilter.core import importance
from skelfilter.mesh import pipeline

noisy, _, _ = pipeline.noisy_mesh(trimesh.creation.box((1.0, 0.8, 0.6)), resolution=128, seed=1)
search = importance.geodesic_importance
def announced(*args):
    print("searching", flush=True)
    return search(*args)
importance.geodesic_importance = announced
while sys.stdin.readline():  # one run per line; both stages: two searches each
    try:
        pipeline.denoise_mesh(noisy, resolution=128, prune="as-told", noise_height=5, output_mesh="closed",
                              stages="both")
        print("finished", flush=True)
    except KeyboardInterrupt as exc:
        print(type(exc).__name__, flush=True)
'''


def test_ctrl_c_in_the_geodesic_search_of_a_library_run_raises_keyboard_interrupt():
    """Ctrl-C in a notebook (a library call, no shield) during the A* of either stage: a segmentation
    fault in 1 of 3 tries, and in the background stage ``SystemError: CPUDispatcher(astar) returned a
    result with an exception set``. Each compiled kernel called from the main thread holds the signal
    until it returns; then Python raises KeyboardInterrupt, and the interpreter carries on."""
    proc = subprocess.Popen([sys.executable, "-c", LIBRARY_RUNS], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    outcomes = []
    try:
        for run, delay_s in enumerate((0.02, 0.02, 0.15, 0.15, 0.3, 0.3, 0.45, 0.45)):
            proc.stdin.write("run\n")
            proc.stdin.flush()
            for _ in range(1 + run % 2):  # the first search, or the background stage's
                assert proc.stdout.readline() == "searching\n", proc.communicate(timeout=60)[1][-2000:]
            time.sleep(delay_s)
            proc.send_signal(signal.SIGINT)
            outcomes.append(proc.stdout.readline().strip())
            if outcomes[-1] != "KeyboardInterrupt":
                break
        proc.stdin.close()
        proc.wait(timeout=120)
    finally:
        proc.kill()
    assert outcomes == ["KeyboardInterrupt"] * 8 and proc.returncode == 0, (
        outcomes, proc.returncode, proc.stderr.read()[-2000:])
