import os

import numpy as np
import pytest
import trimesh

HERE = os.path.dirname(__file__)


def data_path(name):
    """Test meshes shipped with the repository (fandisk ships inside the package as the demo sample)."""
    if name == "fandisk.obj":
        return os.path.join(HERE, "..", "skelfilter", "data", name)
    return os.path.join(HERE, "data", name)


def load(name):
    return trimesh.load(data_path(name), force="mesh", process=False)


def cube_volume(size, pad):
    v = np.zeros((size + 2 * pad,) * 3, dtype=bool)
    v[pad:-pad, pad:-pad, pad:-pad] = True
    return v


@pytest.fixture(scope="session")
def fandisk_128():
    from skelfilter.voxelize import voxelize

    return voxelize(load("fandisk.obj"), 128, 8)[0]
