"""scipy's Gaussian filter of a float32 grid (``mode`` "nearest" or "reflect"), over the cores.

``scipy.ndimage.gaussian_filter`` runs in one thread; the surface's smoothing
(`skelfilter.core.surface_field.smooth_constrained`) filters the whole box of a
256³ grid six times, a tenth of a denoising, and the volume fine pass
(`skelfilter.core.volume_fine_pass`) a few times per level. This is the same
filter, line by line as scipy's ``NI_Correlate1D`` computes it, so the result
is the same float32 bit for bit: each axis in turn (0, 1, 2), the line read as
float64, ``w_0 x_i + Σ_{k = r..1} w_k (x_{i-k} + x_{i+k})`` summed in that
order in float64 (scipy's sum for a symmetric kernel), each axis' result
rounded to float32. Past its ends the line goes on as scipy extends it: mirrored
about its end, again and again ("reflect", scipy's default: ``dcba|abcd|dcba``),
or its edge value repeated ("nearest").
"""

import numpy as np
from numba import prange

from skelfilter.runtime.compiled import njit


def gaussian_weights(sigma, truncate=4.0):
    """The half kernel ``w_0 .. w_r`` of scipy's ``gaussian_filter1d`` (radius ``int(truncate σ + 0.5)``)."""
    radius = int(truncate * float(sigma) + 0.5)
    x = np.arange(-radius, radius + 1)
    phi = np.exp(-0.5 / (float(sigma) * float(sigma)) * x**2)
    phi = phi / phi.sum()
    return np.ascontiguousarray(phi[radius:], dtype=np.float64)


MODES = ("reflect", "nearest")


def gaussian_filter(field, sigma, mode="reflect", truncate=4.0, out=None, scratch=None):
    """``scipy.ndimage.gaussian_filter(field, sigma, mode=mode, truncate=truncate)`` of a float32 3D
    array, the same bits, in parallel.

    Parameters
    ----------
    field : (nx, ny, nz) float32 ndarray
    sigma : float or sequence of 3 floats
        Standard deviation along each axis, in voxels; an axis with sigma 0 is not filtered.
    mode : {"reflect", "nearest"}
        scipy's default, "reflect", or "nearest".
    truncate : float
    out, scratch : float32 ndarray, optional
        Arrays of ``field``'s shape to write the result to and to hold the passes between axes, so
        that repeated filtering reuses its memory (neither may be ``field``).

    Returns
    -------
    float32 ndarray
        ``out`` where given.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy import ndimage
    >>> f = np.random.default_rng(0).random((9, 10, 11)).astype(np.float32)
    >>> bool((gaussian_filter(f, 0.8) == ndimage.gaussian_filter(f, 0.8)).all())
    True
    >>> bool((gaussian_filter(f, 0.8, "nearest") == ndimage.gaussian_filter(f, 0.8, mode="nearest")).all())
    True
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {', '.join(MODES)}, got {mode!r}")
    reflect = mode == "reflect"
    field = np.ascontiguousarray(field, dtype=np.float32)
    if field.ndim != 3:
        raise ValueError(f"a 3D grid is filtered, got {field.ndim} dimensions")
    sigmas = np.broadcast_to(np.asarray(sigma, dtype=float), (3,))
    axes = [axis for axis in range(3) if sigmas[axis] > 1e-15]  # scipy skips an axis of sigma 0
    out = np.empty_like(field) if out is None else out
    if not axes:
        out[...] = field
        return out
    if len(axes) > 1 and scratch is None:
        scratch = np.empty_like(field)
    # The passes alternate between the two arrays so that the last one lands in ``out``.
    source = field
    for n, axis in enumerate(axes):
        target = out if (len(axes) - n) % 2 == 1 else scratch
        weights = gaussian_weights(sigmas[axis], truncate)
        if axis == 2:
            _last_axis(source, weights, reflect, target)
        else:
            _across(source, weights, axis, reflect, target)
        source = target
    return out


@njit(inline="always")
def _extended(i, n, reflect):
    """The index of the line's element that stands at ``i`` once the line is extended past its ends."""
    if 0 <= i < n:
        return i
    if not reflect:
        return min(max(i, 0), n - 1)
    i %= 2 * n
    return i if i < n else 2 * n - 1 - i


@njit(parallel=True)
def _across(source, weights, axis, reflect, out):
    """Axis 0 or 1: the taps are whole rows along axis 2, read in order."""
    nx, ny, nz = source.shape
    radius = weights.size - 1
    n = nx if axis == 0 else ny
    for i in prange(nx):
        line = np.empty(nz, np.float64)
        for j in range(ny):
            at = np.int64(i) if axis == 0 else np.int64(j)
            for k in range(nz):
                line[k] = np.float64(source[i, j, k]) * weights[0]
            for tap in range(radius, 0, -1):
                lo = _extended(at - tap, n, reflect)
                hi = _extended(at + tap, n, reflect)
                w = weights[tap]
                if axis == 0:
                    for k in range(nz):
                        line[k] += (np.float64(source[lo, j, k]) + np.float64(source[hi, j, k])) * w
                else:
                    for k in range(nz):
                        line[k] += (np.float64(source[i, lo, k]) + np.float64(source[i, hi, k])) * w
            for k in range(nz):
                out[i, j, k] = np.float32(line[k])


@njit(parallel=True)
def _last_axis(source, weights, reflect, out):
    """Axis 2: each line copied once, extended past its ends, so that the taps run over whole rows too."""
    nx, ny, nz = source.shape
    radius = weights.size - 1
    for i in prange(nx):
        padded = np.empty(nz + 2 * radius, np.float64)
        line = np.empty(nz, np.float64)
        for j in range(ny):
            for k in range(nz + 2 * radius):
                padded[k] = np.float64(source[i, j, _extended(k - radius, nz, reflect)])
            for k in range(nz):
                line[k] = padded[k + radius] * weights[0]
            for tap in range(radius, 0, -1):
                w = weights[tap]
                for k in range(nz):
                    line[k] += (padded[k + radius - tap] + padded[k + radius + tap]) * w
            for k in range(nz):
                out[i, j, k] = np.float32(line[k])
