"""NumPy ``.npy`` arrays: no geometry (unit spacing unless given), no pickles."""

import numpy as np

from skelfilter.io.volume import Volume
from skelfilter.io.volume_formats import VolumeFormat


def _read_npy(path):
    return Volume(np.load(path, allow_pickle=False), np.eye(4), "npy", None)



def _write_npy(tmp, like, data):
    with open(tmp, "wb") as f:
        np.save(f, data, allow_pickle=False)


FORMAT = VolumeFormat("npy", (".npy",), _read_npy, _write_npy)
