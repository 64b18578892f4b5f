"""A volume in memory: its data indexed ``(i, j, k)`` and the affine that takes an index to world
coordinates, as every volume format module reads and writes it."""

from dataclasses import dataclass

import numpy as np

from skelfilter.errors import InputError, ResourceError
from skelfilter.runtime.memory import available_bytes


@dataclass
class Volume:
    """A volume file's contents.

    Attributes
    ----------
    data : ndarray, 3-D
        The voxel values, indexed ``(i, j, k)``.
    affine : ndarray, shape (4, 4)
        Index to world coordinates.
    format : str
        Its format's name (a module of :mod:`skelfilter.io.volume_formats`: ``nifti``, ``vti``, ...).
    header : object
        The format's own header (nibabel header, NRRD dict, ImageJ metadata), written back as it is.
    """

    data: np.ndarray
    affine: np.ndarray
    format: str
    header: object = None

    @property
    def spacing(self):
        """Voxel size along i, j, k in world units (the lengths of the affine's columns)."""
        return np.linalg.norm(self.affine[:3, :3], axis=0)


def check_claimed_size(path, shape, itemsize, stored=None):
    """Refuse a header whose volume the file cannot hold (``stored``: the bytes it has for the data,
    when it is not compressed) or the memory cannot, before the data is read."""
    shape = tuple(int(n) for n in shape)
    if any(n < 0 for n in shape):
        raise InputError(f"{path}: malformed header (negative size {shape})")
    need_bytes = int(np.prod(shape, dtype=object)) * int(itemsize)
    size = "x".join(map(str, shape))
    if stored is not None and need_bytes > stored:
        raise InputError(f"{path}: malformed file (the header claims a {size} volume of {itemsize}-byte values, "
                         f"{need_bytes} bytes of data; the file holds {max(stored, 0)})")
    have = available_bytes()
    if need_bytes > have:
        raise ResourceError(f"{path}: the header claims a {size} volume of {itemsize}-byte values, "
                            f"{need_bytes / 2**30:.1f} GiB, but only {have / 2**30:.1f} GiB is available")
