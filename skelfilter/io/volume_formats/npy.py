"""NumPy ``.npy`` arrays: no geometry (unit spacing unless given), no pickles."""

import os

import numpy as np

from skelfilter.io.volume import Volume, check_claimed_size
from skelfilter.io.volume_formats import VolumeFormat


def _read_npy(path):
    with open(path, "rb") as f:  # the header's shape against the file's bytes, before the data is read
        version = np.lib.format.read_magic(f)
        header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        shape, _, dtype = header(f)
        offset = f.tell()
    if not dtype.hasobject:  # an object array is refused by the reader (no pickles)
        check_claimed_size(path, shape, dtype.itemsize, os.path.getsize(path) - offset)
    return Volume(np.load(path, allow_pickle=False), np.eye(4), "npy", None)


def _write_npy(tmp, like, data):
    with open(tmp, "wb") as f:
        np.save(f, data, allow_pickle=False)


FORMAT = VolumeFormat("npy", (".npy",), _read_npy, _write_npy)
