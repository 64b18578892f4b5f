"""The continuous field whose 0-level is the output surface: balls' union of a binary volume, the
input's own distances kept where the denoising changed nothing, and the field smoothed under the
voxels' constraint so that its surface is smooth and still encloses exactly the voxels it is of."""

import numpy as np
from scipy import ndimage

from skelfilter.core import reconstruct

# Balls of radius D touch the centres of the nearest outside voxels; the
# boundary between inside and outside voxel centres is half a voxel further in.
SURFACE_OFFSET = 0.5
# The sign-constrained smoothing (`smooth_constrained`): the Gaussian's sigma in voxels of the grid
# (along each axis, so thick slices are smoothed over as many slices as thin ones over pixels), and
# the rounds of smoothing then projection. Chosen on benchmarks/surfaces.py's tuning label maps.
SMOOTHING_SIGMA = 0.8
SMOOTHING_ROUNDS = 3
# Voxels: how far inside (outside) its voxel centre's value is held at least, so no vertex of the
# marching cubes lands on a centre (no triangle without area).
CONSTRAINT_MARGIN = 0.02


def unchanged_band(field, mask, occupancy, reach):
    """Flat indices of the voxels whose field values shape the 0-level (``|field| < 1.5``) and lie
    more than ``reach`` voxels (6-connected steps) from any voxel the denoising changed."""
    near_change = ndimage.binary_dilation(mask != occupancy, iterations=reach)
    return np.flatnonzero((np.abs(field) < 1.5).reshape(-1) & ~near_change.reshape(-1))


def put_distances(field, mask, band, distance):
    """``field[band]`` = ``distance`` with the mask's sign, so the mesh and the voxels still agree."""
    flat = field.reshape(-1)
    flat[band] = np.where(mask.reshape(-1)[band], 1.0, -1.0) * np.maximum(np.abs(distance), 1e-3)


def keep_input_field(field, mask, occupancy, input_field, reach=2):
    """`skelfilter.mesh.marching_cubes.keep_input_surface` for a volume: where the denoising changed
    nothing, ``field`` takes the input's own ``input_field`` (in voxels, > 0 inside, e.g.
    `skelfilter.core.spacing.signed_distance`). In place."""
    band = unchanged_band(field, mask, occupancy, reach)
    put_distances(field, mask, band, input_field.reshape(-1)[band])


def mask_field(mask):
    """Continuous field of a binary volume: the union of the balls of all its voxels.

    Same construction as the pipeline's reconstruction without pruning, so
    meshes of noisy and of denoised volumes are extracted alike.
    """
    distance = ndimage.distance_transform_edt(mask)
    centres = np.flatnonzero(mask.reshape(-1))
    radii = distance.reshape(-1)[centres] - SURFACE_OFFSET
    return reconstruct.union_of_balls(mask.shape, centres, radii)[1]


def smooth_constrained(field, inside, fixed=None, unit=1.0, sigma=SMOOTHING_SIGMA, rounds=SMOOTHING_ROUNDS):
    """The smoothest field near ``field`` whose sign at every voxel centre is ``inside``'s.

    A voxel mask is the sampling of a smooth surface: each set voxel's centre lies inside it, each
    other centre outside, and nothing more is known of where between two centres it passes. Each
    round smooths the field by a low-pass that does not shrink (twicing of a Gaussian,
    ``2 G f - G G f``: its response ``1 - (1 - g)^2`` is flat to fourth order, so a sphere or a
    cylinder keeps its radius where a Gaussian would move its surface in by its curvature times
    sigma squared), then puts every voxel centre back on its own side of the surface (at least
    `CONSTRAINT_MARGIN` voxels' worth of field) and ``fixed`` voxels back to their values. The
    marching cubes of the result encloses exactly the ``inside`` voxels, staircase removed.

    Parameters
    ----------
    field : float ndarray
        > 0 inside; in any unit common to the axes (e.g. `skelfilter.core.spacing.signed_distance`
        in world units).
    inside : bool ndarray
        The voxels whose centres must stay inside, same shape.
    fixed : bool ndarray, optional
        Voxels whose values are kept as they are (a surface already known to sub-voxel precision).
    unit : float
        The field's value one voxel (the finest spacing) deep: sets the margin.
    sigma : float or sequence of floats
        Voxels (index units), or one per axis.
    rounds : int

    Returns
    -------
    float32 ndarray
        The smoothed field.

    References
    ----------
    .. [1] R. T. Whitaker, "Reducing aliasing artifacts in iso-surfaces of binary volumes", IEEE
           Symposium on Volume Visualization 2000 (the sign constraint at the voxel centres).
    .. [2] V. Lempitsky, "Surface extraction from binary volumes with higher-order smoothness",
           CVPR 2010 (a higher-order smoothness: no shrinking).
    .. [3] J. W. Tukey, *Exploratory data analysis*, 1977 ("twicing").

    Examples
    --------
    >>> import numpy as np
    >>> i, j, k = np.indices((24, 24, 24)) - 11.5
    >>> ball = i**2 + j**2 + k**2 < 8.3**2
    >>> from skelfilter.core.spacing import signed_distance
    >>> field = smooth_constrained(signed_distance(ball, (1.0, 1.0, 1.0)), ball)
    >>> bool(((field > 0) == ball).all())
    True
    """
    inside = np.asarray(inside, dtype=bool)
    original = np.asarray(field, dtype=np.float32)
    current = original.copy()
    margin = np.float32(CONSTRAINT_MARGIN * unit)
    for _ in range(rounds):
        once = ndimage.gaussian_filter(current, sigma, mode="nearest")
        current = 2 * once - ndimage.gaussian_filter(once, sigma, mode="nearest")
        np.maximum(current, margin, out=current, where=inside)
        np.minimum(current, -margin, out=current, where=~inside)
        if fixed is not None:
            current[fixed] = original[fixed]
    return current
