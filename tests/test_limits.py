"""The process's limits and environment: an address-space limit (``ulimit -v``), a threading layer
chosen by ``NUMBA_THREADING_LAYER``, a ``fork()`` after a run. Each case runs in a child process."""

import os
import subprocess
import sys

import numpy as np
import pytest
import trimesh

SCRIPT = ('<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name="Skeleton Saliency Denoise">\n'
          '  <Param name="resolution" type="RichInt" value="40"/>\n </filter>\n</FilterScript>\n')
# What the command reports of its process: its peak of address space, once it has run.
PEAK = ("import sys\nfrom skelfilter.cli import main\nstatus = main(sys.argv[1:])\n"
        "print([line.split()[1] for line in open('/proc/self/status') if line.startswith('VmPeak')][0])\n"
        "sys.exit(status)\n")


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    root = tmp_path_factory.mktemp("inputs")
    volume = np.zeros((30, 30, 30), np.uint8)
    volume[8:22, 8:22, 8:22] = 1
    np.save(root / "volume.npy", volume)
    trimesh.creation.icosphere(3).export(root / "sphere.ply")
    np.savetxt(root / "cloud.xyz", trimesh.creation.icosphere(4).vertices)
    (root / "script.mlx").write_text(SCRIPT)
    return root


def _under_limit(argv, limit_kib, cwd):
    """The CLI with ``argv`` in a shell that limits the address space to ``limit_kib``."""
    return subprocess.run(["bash", "-c", f'ulimit -v {limit_kib}; exec "$@"', "bash", sys.executable, "-c", PEAK,
                           *argv], cwd=cwd, capture_output=True, text=True, timeout=600)


def test_an_address_space_limit_too_small_for_a_library_is_named_in_one_line(inputs, tmp_path):
    """Under ``ulimit -v`` (1 GB when it was found) open3d's 800 MB library cannot be mapped: a cloud
    printed an ImportError traceback, a batch of clouds failed every file without saying why. The
    commands that do not need it (volumes, scripts) do not load it and run."""
    volume = ["denoise", str(inputs / "volume.npy"), str(tmp_path / "volume.npy"), "--quiet"]
    unlimited = subprocess.run([sys.executable, "-c", PEAK, *volume], capture_output=True, text=True, timeout=600)
    assert unlimited.returncode == 0, unlimited.stderr
    # room for the volume's run, well short of what open3d maps (its library alone is 800 MB)
    limit_kib = int(unlimited.stdout.split()[-1]) + 300_000
    runs = {"volume": volume,
            "script": ["run-script", str(inputs / "script.mlx"), str(inputs / "sphere.ply"),
                       str(tmp_path / "scripted.ply")]}
    for what, argv in runs.items():
        done = _under_limit(argv, limit_kib, tmp_path)
        assert done.returncode == 0, (what, done.stderr[-2000:])
    cloud = _under_limit(["denoise", str(inputs / "cloud.xyz"), str(tmp_path / "cloud.ply")], limit_kib, tmp_path)
    lines = cloud.stderr.strip().splitlines()
    assert cloud.returncode == 2 and len(lines) == 1, cloud.stderr[-2000:]
    assert lines[0].startswith("skelfilter: error: ") and "address space" in lines[0] and "ulimit -v" in lines[0]
    assert not (tmp_path / "cloud.ply").exists()
    batch = _under_limit(["batch", str(inputs / "cloud.xyz"), "--out", str(tmp_path / "batch"), "--workers", "1"],
                         limit_kib, tmp_path)
    assert batch.returncode != 0 and "address space" in batch.stderr.splitlines()[-1], batch.stderr[-2000:]


@pytest.mark.parametrize("layer, named", [("tbb", "TBB"), ("no-such-layer", "unknown")])
def test_a_threading_layer_numba_cannot_start_is_named_in_one_line(inputs, tmp_path, layer, named):
    """``NUMBA_THREADING_LAYER=tbb`` where TBB is not installed (numba's TBB module hidden here, so
    that the case is the same where it is) printed numba's traceback. The user chose the layer: it is
    not replaced behind their back, the line names the variable and what to do."""
    code = ("import sys\nsys.modules['numba.np.ufunc.tbbpool'] = None  # as where TBB is not installed\n"
            "from skelfilter.cli import main\nsys.exit(main(sys.argv[1:]))\n")
    done = subprocess.run([sys.executable, "-c", code, "denoise", str(inputs / "volume.npy"),
                           str(tmp_path / "out.npy")], env={**os.environ, "NUMBA_THREADING_LAYER": layer},
                          capture_output=True, text=True, timeout=600)
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1, done.stderr[-2000:]
    assert lines[0].startswith(f"skelfilter: error: NUMBA_THREADING_LAYER={layer}: ") and named in lines[0]
    assert "unset NUMBA_THREADING_LAYER" in lines[0]
    assert not (tmp_path / "out.npy").exists()


FORK = r'''
import os, sys
import numba
import trimesh
from skelfilter.mesh import pipeline

box = trimesh.creation.box()
faces = len(pipeline.denoise_mesh(box, resolution=32, output_mesh="closed").faces)
print(numba.threading_layer(), flush=True)
pid = os.fork()
if pid == 0:  # as multiprocessing's 'fork' start method does
    try:
        same = len(pipeline.denoise_mesh(box, resolution=32, output_mesh="closed").faces) == faces
    except BaseException as exc:
        print(f"the child raised {exc!r}", flush=True)
        os._exit(3)
    os._exit(0 if same else 4)
print(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]), flush=True)
print(len(pipeline.denoise_mesh(box, resolution=32, output_mesh="closed").faces) == faces)
'''


@pytest.mark.parametrize("layer", ["default", "omp", "workqueue"])
def test_a_process_forked_after_a_run_denoises(layer):
    """A library run, then ``fork()`` (multiprocessing's 'fork' start method): numba's GNU OpenMP
    layer, the one it picks on Linux without TBB, killed the child (SIGTERM, numba's line
    "fork() called from a process already using GNU OpenMP"). The child runs the kernels serially
    instead; the parent keeps its threads. The threading layer stays the user's (or numba's) choice:
    workqueue is fork-safe but not thread-safe."""
    done = subprocess.run([sys.executable, "-c", FORK], env={**os.environ, "NUMBA_THREADING_LAYER": layer},
                          capture_output=True, text=True, timeout=600)
    lines = done.stdout.split()
    assert done.returncode == 0 and lines[1:] == ["0", "True"], (done.stdout, done.stderr[-2000:])
    if layer != "default":
        assert lines[0] == layer
