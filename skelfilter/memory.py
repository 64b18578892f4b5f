"""Memory estimate of a run, checked before any grid is allocated."""

import os

from .errors import ResourceError

# Peak bytes per grid voxel of one pipeline stage: scipy's EDT with indices
# (float64 distances + 3 int32 indices), the float32 EDT kept, the reverse
# EDT's float32 power and int32 owner, the field and a few boolean masks.
BYTES_PER_VOXEL = 48


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
