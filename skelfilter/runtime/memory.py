"""Memory estimate of a run, checked before any grid is allocated."""

import ctypes
import os
import resource

import numpy as np

from skelfilter.errors import ResourceError

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
# Peak bytes per input face of the mesh stages (voxelization, the fine pass on the input's vertices):
# measured 1 248 on a noisy 327 680-face sphere, rounded up.
BYTES_PER_FACE = 1300

_CGROUP_ROOT = "/sys/fs/cgroup"
# cgroup v1 writes "no limit" as a page-rounded 2**63 - 1.
_UNLIMITED = 2**62


def available_bytes():
    """Memory a new allocation can get: the least of the system's available RAM, what the
    process limits (``ulimit -v``, ``ulimit -d``) leave and what the memory cgroup leaves."""
    return min(_system_available(), _rlimit_left(), _cgroup_left())


def _system_available():
    """Linux MemAvailable; total RAM elsewhere."""
    value = _proc_field("/proc/meminfo", "MemAvailable")
    if value is not None:
        return value
    return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")


def read_field(path, name):
    """The value of the line ``name: value ...`` or ``name value`` of a Linux /proc or /sys file, as
    text; None when the file or the line is missing (not Linux, no such cgroup)."""
    try:
        with open(path) as f:
            for line in f:
                key, *value = line.split()
                if key.rstrip(":") == name and value:
                    return value[0]
    except OSError:
        return None
    return None


def _proc_field(path, name):
    """A ``name: N kB`` line of a /proc file, in bytes (None when absent)."""
    value = read_field(path, name)
    return None if value is None else int(value) * 1024


def _rlimit_left():
    """What RLIMIT_AS and RLIMIT_DATA leave beyond the process' current virtual and data size."""
    left = _UNLIMITED
    for limit, used_field in ((resource.RLIMIT_AS, "VmSize"), (resource.RLIMIT_DATA, "VmData")):
        soft = resource.getrlimit(limit)[0]
        if soft != resource.RLIM_INFINITY:
            left = min(left, soft - (_proc_field("/proc/self/status", used_field) or 0))
    return max(left, 0)


def _read_number(path):
    try:
        with open(path) as f:
            text = f.read().strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None


def _reclaimable(stat_path, field):
    """Page cache the kernel drops before failing an allocation (``inactive_file``)."""
    value = read_field(stat_path, field)
    return int(value) if value is not None and value.isdigit() else 0


def _cgroup_left():
    """What the memory cgroup's limit leaves (v2 ``memory.max``, v1 ``memory.limit_in_bytes``),
    from the cgroup mount as seen inside the process' namespace."""
    left = _UNLIMITED
    for folder, limit, usage, stat, reclaimable in (
            (_CGROUP_ROOT, "memory.max", "memory.current", "memory.stat", "inactive_file"),
            (os.path.join(_CGROUP_ROOT, "memory"), "memory.limit_in_bytes", "memory.usage_in_bytes",
             "memory.stat", "total_inactive_file")):
        cap = _read_number(os.path.join(folder, limit))
        used = _read_number(os.path.join(folder, usage))
        if cap is None or used is None or cap >= _UNLIMITED:
            continue
        used -= _reclaimable(os.path.join(folder, stat), reclaimable)
        left = min(left, cap - max(used, 0))
    return max(left, 0)


def check_grid_fits(shape, available=None, padding=0, padding_from="`padding`", faces=0):
    """Raise ResourceError when a grid of ``shape`` (and a mesh of ``faces`` triangles) would not fit
    in memory.

    ``padding`` (voxels on each side) and ``padding_from`` (the parameters that set it, backticked as
    in every message: the CLI names them by their flags) make the advice point at the padding when it
    makes most of the grid; the advice points at the mesh when its faces make most of the need.
    """
    n = int(shape[0]) * int(shape[1]) * int(shape[2])
    need = n * BYTES_PER_VOXEL + int(faces) * BYTES_PER_FACE
    have = available_bytes() if available is None else available
    if need > have:
        inner = int(np.prod([max(int(s) - 2 * padding, 1) for s in shape]))
        if faces * BYTES_PER_FACE > n * BYTES_PER_VOXEL:
            raise ResourceError(f"the mesh's {faces} faces need about {need / 2**30:.1f} GiB with the grid but only "
                                f"{have / 2**30:.1f} GiB is available; simplify the mesh (MeshLab's Quadric "
                                "Edge Collapse Decimation) or free memory")
        advice = (f"the padding of {padding} voxels on each side makes most of it; lower {padding_from}"
                  if inner < n / 2 else "lower `resolution`")
        raise ResourceError(
            f"a {shape[0]}x{shape[1]}x{shape[2]} grid needs about {need / 2**30:.1f} GiB "
            f"but only {have / 2**30:.1f} GiB is available; {advice}"
        )
    return need


def return_freed_memory():
    """Have glibc give every freed block over 128 KiB back to the system at once (a setting of the
    process: the CLI and the batch workers make it when they start, a library call never does).

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
