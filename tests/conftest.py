import os
import shutil
import signal
import sys

import numpy as np
import pytest
import trimesh

HERE = os.path.dirname(__file__)


def pytest_configure(config):
    """A shell starts background jobs (``make test &``, ``nohup``) with SIGINT (and SIGHUP) ignored,
    and a child inherits an ignored signal: the CLI rightly keeps it so, and the interrupt tests would
    see their signals ignored. Here they get handlers of Python's own, which a child does not inherit:
    the children start with the default dispositions, and this process still ignores a hang-up."""
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if signal.getsignal(signal.SIGHUP) is signal.SIG_IGN:
        signal.signal(signal.SIGHUP, lambda signum, frame: None)


PACKAGE_DATA = os.path.join(HERE, "..", "skelfilter", "data")


def skelfilter_command():
    """The ``skelfilter`` console script installed for the interpreter running the tests (beside it, as
    in a virtual environment that is not activated), else the one on the PATH: not another
    installation's."""
    beside = os.path.join(os.path.dirname(sys.executable), "skelfilter")
    return beside if os.path.exists(beside) else shutil.which("skelfilter") or "skelfilter"


def data_path(name):
    """Test meshes shipped with the repository: the package's sample meshes (the demo's fandisk, the
    comparison's models), else the tests' own fixtures."""
    packaged = os.path.join(PACKAGE_DATA, name)
    return packaged if os.path.exists(packaged) else os.path.join(HERE, "data", name)


def load(name):
    return trimesh.load(data_path(name), force="mesh", process=False)


def cube_volume(size, pad):
    v = np.zeros((size + 2 * pad,) * 3, dtype=bool)
    v[pad:-pad, pad:-pad, pad:-pad] = True
    return v


@pytest.fixture(scope="session")
def fandisk_128():
    from skelfilter.mesh.voxelize import voxelize

    return voxelize(load("fandisk.obj"), 128, 8)[0]


@pytest.fixture
def meshlab_fault(monkeypatch):
    """``meshlab_fault("abort")`` / ``("sleep@1")``: MeshLab's child processes of this test abort or
    hang before the given step (`harness.meshlab_child_fault`)."""
    import harness

    def inject(action):
        monkeypatch.setenv("PYTHONPATH", harness.with_harness_path(dict(os.environ))["PYTHONPATH"])
        harness.meshlab_child_fault(action, monkeypatch.setattr)

    return inject


def cube_with_a_bump_and_a_dent():
    """(clean, noisy): a 24-voxel cube in a 40³ grid, with a bump 3 voxels high and a dent 3 deep on its top."""
    clean = np.zeros((40, 40, 40), dtype=bool)
    clean[8:32, 8:32, 8:32] = True
    noisy = clean.copy()
    noisy[14:18, 14:18, 32:35] = True
    noisy[22:26, 22:26, 29:32] = False
    return clean, noisy
