"""Memory estimate of a run, checked before any grid is allocated."""

import ctypes
import os

from .errors import ResourceError

# glibc's mallopt parameter, and the size from which blocks get their own mapping.
_M_MMAP_THRESHOLD = -3
_MMAP_THRESHOLD = 128 * 1024

# Peak resident bytes per grid voxel of a whole run, mesh file to mesh file:
# a stage holds the float32 EDT with the int32 feature transform (or, later,
# an int32 neighbour lookup, or the int32 owner turned float32 field) and a
# few boolean masks, about 14 bytes; the rest is the interpreter, the meshes
# and the skeleton's flat arrays. Measured 33.9 at 384 (fandisk, the
# benchmark), less on larger grids; rounded up.
BYTES_PER_VOXEL = 36


def available_bytes():
    """Memory available to a new allocation (Linux MemAvailable; total RAM elsewhere)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def check_grid_fits(shape, available=None):
    """Raise ResourceError when a grid of ``shape`` would not fit in memory."""
    n = int(shape[0]) * int(shape[1]) * int(shape[2])
    need = n * BYTES_PER_VOXEL
    have = available_bytes() if available is None else available
    if need > have:
        raise ResourceError(
            f"a {shape[0]}x{shape[1]}x{shape[2]} grid needs about {need / 2**30:.1f} GiB "
            f"but only {have / 2**30:.1f} GiB is available; lower --resolution"
        )
    return need


def return_freed_memory():
    """Have glibc give every freed block over 128 KiB back to the system at once.

    After each large free glibc raises its mmap threshold (up to 32 MiB), so
    later arrays below it are carved from heaps that keep their pages when
    freed: the resident peak of a run then grows with everything earlier
    steps freed. A fixed threshold (glibc's initial one) keeps large arrays
    in mappings of their own. Returns False where there is no glibc.
    """
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:
        return False
    return bool(libc.mallopt(_M_MMAP_THRESHOLD, _MMAP_THRESHOLD))
