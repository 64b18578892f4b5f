"""Voxel neighbourhoods shared by every stage.

Conventions used throughout skelfilter:

* a volume is a C-ordered numpy array of shape ``(nx, ny, nz)``; voxel
  ``(i, j, k)`` is the cell whose centre sits at ``grid.origin + (i, j, k) * grid.pitch``;
* a set of voxels is passed around as flat indices (``np.int64``) into the
  raveled C-ordered volume, and quantities over it as flat arrays aligned
  with those indices (never as dense grids);
* distances are in voxels unless a name says ``_world``.
"""

import numpy as np

from skelfilter.runtime.compiled import njit

# The 26 neighbours of the origin (the 3x3x3 cube minus its centre), eq. 7.12's b.
OFFSETS_26 = np.array(
    [(i, j, k) for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1) if (i, j, k) != (0, 0, 0)],
    dtype=np.int64,
)
STEP_LENGTHS_26 = np.sqrt((OFFSETS_26**2).sum(axis=1))

# The 6 face neighbours.
OFFSETS_6 = np.array(
    [(-1, 0, 0), (1, 0, 0), (0, -1, 0), (0, 1, 0), (0, 0, -1), (0, 0, 1)], dtype=np.int64
)


def flat_offsets(shape, offsets):
    """Flat-index displacement of each 3-D offset in a C-ordered volume of ``shape``."""
    strides = np.array([shape[1] * shape[2], shape[2], 1], dtype=np.int64)
    return np.asarray(offsets, dtype=np.int64) @ strides


def ball_offsets(radius):
    """Integer offsets ``o`` with ``|o| <= radius``, and their lengths."""
    r = int(np.floor(radius))
    ax = np.arange(-r, r + 1)
    o = np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), axis=-1).reshape(-1, 3)
    length = np.sqrt((o**2).sum(axis=1))
    keep = length <= radius + 1e-9
    return o[keep].astype(np.int64), length[keep]


def unravel(flat, shape):
    """``(n, 3)`` int64 voxel coordinates of flat indices."""
    return np.stack(np.unravel_index(np.asarray(flat, dtype=np.int64), shape), axis=1).astype(np.int64)


def ravel(coords, shape):
    """Flat indices of ``(n, 3)`` voxel coordinates."""
    c = np.asarray(coords, dtype=np.int64)
    return (c[:, 0] * shape[1] + c[:, 1]) * shape[2] + c[:, 2]


def has_border_margin(volume, margin=1):
    """True when no set voxel lies within ``margin`` voxels of the volume's faces."""
    v = np.asarray(volume, dtype=bool)
    m = margin
    inner = v[m:-m, m:-m, m:-m].sum() if all(s > 2 * m for s in v.shape) else 0
    return int(inner) == int(v.sum())


def bounding_box(volume, margin=0):
    """Slices of the smallest box holding every set voxel, widened by ``margin`` and clipped to the volume.

    Found from the set's projections on the three axes, without listing its
    voxels. ``None`` when no voxel is set.
    """
    box = []
    for axis in range(3):
        hit = np.flatnonzero(volume.any(axis=tuple(a for a in range(3) if a != axis)))
        if not len(hit):
            return None
        box.append(slice(max(int(hit[0]) - margin, 0), int(hit[-1]) + 1 + margin))
    return tuple(box)


@njit()
def push(stack, top, value):
    """Push ``value`` on the int64 array ``stack`` whose first ``top`` entries are in use, doubling it
    when full (numba kernels' work lists); returns the stack and the new ``top``."""
    if top == stack.size:
        stack = np.concatenate((stack, np.empty(stack.size, dtype=np.int64)))
    stack[top] = value
    return stack, top + 1
