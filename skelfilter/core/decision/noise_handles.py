"""Noise handles: the small tunnels that noise leaves through a denoised shape, found and filled.

Where bumps stood side by side, or a bump arched over a dent, the pruning and the features kept
leave voxel tunnels a voxel or two wide: the shape's genus rises by one per tunnel (noisy fandisk
with the thesis' stripes came out of the stages at genus 27, the clean part has 0; a mug with bumps
and dents at 1 471, the clean mug has 1). A tunnel the shape has (a mug's handle, a ring, the gap
under an arm) is wider than the noise's.

`filled_noise_handles` fills the holes that a closing by the 6-neighbour cross fills (gaps one voxel
wide), but only those whose filling closes a tunnel: each 26-connected piece of the closing's new
voxels is filled where it raises the Euler characteristic of the shape (`euler_change`), joins no
two pieces of it and seals no cavity. A piece that only fills a pit or a crease leaves the
characteristic as it was, and stays open: the step adds no material but the tunnels' own.

The Euler characteristic of a voxel set taken as closed unit cubes (the cubical complex of the
26-connected set) is chi = V - E + F - C over the vertices, edges, faces and cubes it holds, and for
a solid chi = b0 - g + c (pieces, tunnels, cavities): filling a piece that adds no cavity and joins
no pieces lowers g by exactly the rise of chi. Adding voxels changes only the cells they touch that
the shape did not, so the change is counted at the new voxels alone.

References
----------
.. [1] T. Y. Kong and A. Rosenfeld, "Digital topology: introduction and survey", Computer Vision,
       Graphics, and Image Processing 48 (1989), 357-393 (the Euler characteristic of a voxel set,
       26/6 connectivity).
.. [2] Q.-Y. Zhou, T. Ju and S.-M. Hu, "Topology repair of solid models using skeletons", IEEE
       Transactions on Visualization and Computer Graphics 13 (2007), 675-685 (handles removed by the
       smaller of a fill and a cut).
"""

import numpy as np
from scipy import ndimage

from skelfilter.core.neighbourhood import CUBE, OFFSETS_26, bounding_box, dilated_by_cross

# The 27 cells a voxel touches (8 vertices, 12 edges, 6 faces, itself), as offsets on the doubled
# lattice where voxel (i, j, k) is the cube centred at (2i+1, 2j+1, 2k+1): a cell's coordinate is odd
# along the axes it spans.
_CELL_OFFSETS = np.stack(np.meshgrid(*([np.arange(-1, 2)] * 3), indexing="ij"), axis=-1).reshape(-1, 3)


def euler_change(mask, added, labels, count):
    """The change of the Euler characteristic of ``mask`` (voxels as closed cubes) when each
    26-connected piece of ``added`` is added to it alone.

    Parameters
    ----------
    mask, added : (nx, ny, nz) bool ndarray
        The shape, and voxels outside it.
    labels : (nx, ny, nz) int ndarray
        ``added``'s 26-connected pieces numbered 1 to ``count`` (`scipy.ndimage.label` with the 3x3x3
        cube), 0 elsewhere.
    count : int

    Returns
    -------
    (count + 1,) int64 ndarray
        Entry k: chi(mask | piece k) - chi(mask); entry 0 is 0.

    Notes
    -----
    Two pieces touch no common cell (voxels sharing a vertex are 26-neighbours), so the cells a piece
    adds are those it touches and ``mask`` does not, each counted with the sign (-1)^dimension.

    Examples
    --------
    >>> import numpy as np
    >>> ring = np.zeros((5, 5, 3), bool); ring[1:4, 1:4, 1] = True; ring[2, 2, 1] = False
    >>> hole = np.zeros_like(ring); hole[2, 2, 1] = True
    >>> int(euler_change(ring, hole, hole.astype(int), 1)[1])  # filling the ring's hole: chi 0 -> 1
    1
    """
    total = np.zeros(count + 1, dtype=np.int64)
    centres = np.argwhere(added)
    if not len(centres):
        return total
    piece = labels[added]
    cells = (2 * centres + 1)[:, None, :] + _CELL_OFFSETS[None, :, :]
    cells = cells.reshape(-1, 3)
    extent = 2 * np.asarray(mask.shape, dtype=np.int64) + 1
    _, first = np.unique(np.ravel_multi_index(tuple(cells.T), extent), return_index=True)
    cells, piece = cells[first], np.repeat(piece, len(_CELL_OFFSETS))[first]
    # The voxels around a cell: along an axis it spans (odd coordinate) one, else the two beside it;
    # read on the mask padded by one, so that a cell on the array's face sees the empty outside.
    padded = np.pad(mask, 1)
    touched = np.zeros(len(cells), dtype=bool)
    for corner in np.ndindex(2, 2, 2):
        voxel = (cells - 1 + np.asarray(corner)) // 2 + 1
        touched |= padded[voxel[:, 0], voxel[:, 1], voxel[:, 2]]
    sign = 1 - 2 * ((cells % 2).sum(axis=1) % 2)
    new = ~touched
    total += np.bincount(piece[new], weights=sign[new], minlength=count + 1).astype(np.int64)
    return total


def filled_noise_handles(mask):
    """The voxels that close the noise's tunnels through ``mask``.

    The holes of ``mask`` that a closing by the 6-neighbour cross fills, taken piece by piece
    (26-connected) where filling the piece raises the Euler characteristic (`euler_change`: a tunnel
    closed), joins no two pieces of ``mask`` and leaves no cavity beside it (a pocket sealed is no
    tunnel closed).

    Parameters
    ----------
    mask : (nx, ny, nz) bool ndarray

    Returns
    -------
    filled : (nx, ny, nz) bool ndarray
        Voxels outside ``mask``; ``mask | filled`` has the same pieces and cavities as ``mask``.
    closed : int
        The tunnels closed: the rise of the Euler characteristic, the fall of the genus.

    Examples
    --------
    >>> import numpy as np
    >>> block = np.zeros((12, 12, 12), bool); block[2:10, 2:10, 2:10] = True
    >>> block[5, 5, 2:10] = False                          # a one-voxel tunnel through it: genus 1
    >>> filled, closed = filled_noise_handles(block)
    >>> int(filled.sum()), closed                          # its middle: the mouths stay pits
    (6, 1)
    >>> ring = np.zeros((16, 16, 6), bool); ring[2:14, 2:14, 2:4] = True
    >>> ring[5:11, 5:11, 2:4] = False                      # a ring's hole, six voxels wide, stays
    >>> filled_noise_handles(ring)[1]
    0
    """
    filled = np.zeros_like(mask, dtype=bool)
    box = bounding_box(mask, margin=2)
    if box is None:
        return filled, 0
    shape = mask[box]
    closed = ~dilated_by_cross(~dilated_by_cross(shape))
    holes = closed & ~shape
    labels, count = ndimage.label(holes, CUBE)
    if not count:
        return filled, 0
    change = euler_change(shape, holes, labels, count)
    rises = change > 0  # entry 0 (no piece) stays False: every update below leaves it
    rises[_joining(shape, labels, count)] = False
    # A piece inside a cavity of the shape fills (part of) it, and one beside a cavity of the filled
    # shape sealed it (or lies in one): either changes the characteristic by more than tunnels.
    rises[labels[_cavities(shape) & holes]] = False
    fill = rises[labels]
    sealed = _cavities(shape | fill)
    if sealed.any():
        rises[labels[dilated_by_cross(sealed) & fill]] = False
        fill = rises[labels]
    filled[box] = fill
    return filled, int(change[rises].sum())


def _joining(shape, labels, count):
    """The hole pieces (1 to ``count`` of ``labels``) that touch two pieces of ``shape`` or more."""
    pieces, _ = ndimage.label(shape, CUBE)
    at = np.argwhere(labels > 0)
    hole = labels[tuple(at.T)]
    padded = np.pad(pieces, 1)
    none = np.iinfo(np.int64).max  # no piece of the shape beside: the least stays above the most (0)
    low = np.full(len(at), none, dtype=np.int64)
    high = np.zeros(len(at), dtype=np.int64)
    for offset in OFFSETS_26:
        near = padded[tuple((at + 1 + offset).T)]
        high = np.maximum(high, near)
        low = np.where(near > 0, np.minimum(low, near), low)
    least = np.full(count + 1, none, dtype=np.int64)
    most = np.zeros(count + 1, dtype=np.int64)
    np.minimum.at(least, hole, low)
    np.maximum.at(most, hole, high)
    return most > least


def _cavities(solid):
    """The voxels of the background's pieces (6-connected) that do not reach the array's faces."""
    outside, _ = ndimage.label(~solid)
    faces = np.unique(np.concatenate([np.moveaxis(outside, axis, 0)[end].ravel()
                                      for axis in range(3) for end in (0, -1)]))
    return (outside > 0) & ~np.isin(outside, faces)
