"""Reconstruction of a shape from skeleton centres and ball radii (thesis §2.2.4, §7.4).

The union of balls (eq. 7.25) is recovered in time linear in the grid size by the
reverse Euclidean distance transform (REDT, eq. 7.26-7.27). Its test
``max_y (D(y) - |x - y|) > 0`` has the sign of the *power*
``max_y (D(y)^2 - |x - y|^2)``, which is separable per axis: three 1-D passes
of the upper envelope of downward parabolas, the Felzenszwalb-Huttenlocher
lower-envelope algorithm applied to ``-f`` as in Coeurjolly & Montanvert's REDT.

Only the winning centre (``owner``) is carried between passes; a site's value
is recomputed from it exactly in float64 as ``r^2 - |x - c|^2``, so the power is
exact whenever the squared radii are integers (as with EDT radii). The field
``r - |x - c|`` of the owner has the power's sign, so the pipeline keeps only
the owner (`union_of_balls`).
"""

import numpy as np
from numba import prange

from skelfilter.core.neighbourhood import unravel
from skelfilter.errors import ParameterError
from skelfilter.runtime.compiled import njit


def squared_radii(radii):
    """Squared radii in float64, snapped to integers within the input's precision.

    EDT radii are square roots of integers, but ``sqrt(k)**2`` rounds to
    ``k * (1 +- eps)``, which would put the background voxel at squared distance
    ``k`` inside the open ball. A squared radius within ``2 eps`` (relative, eps of
    ``radii``' floating dtype) of an integer is taken as that integer.
    """
    r = np.asarray(radii)
    eps = np.finfo(r.dtype).eps if np.issubdtype(r.dtype, np.floating) else 0.0
    r2 = r.astype(np.float64) ** 2
    k = np.round(r2)
    return np.where(np.abs(r2 - k) <= 2 * eps * np.maximum(r2, 1.0), k, r2)


def _validate(shape, centres, radii):
    shape = tuple(int(s) for s in shape)
    if len(shape) != 3 or min(shape) < 1:
        raise ParameterError(f"shape must be three positive sizes, got {shape}")
    centres = np.asarray(centres, dtype=np.int64).ravel()
    radii = np.asarray(radii)
    if radii.shape != centres.shape:
        raise ParameterError(f"{centres.size} centres but radii of shape {radii.shape}")
    if centres.size and (centres.min() < 0 or centres.max() >= np.prod(shape)):
        raise ParameterError("centres must be flat indices into the volume")
    if not np.all(np.isfinite(radii)) or np.any(radii < 0):
        raise ParameterError("radii must be finite and >= 0")
    return shape, centres, radii


@njit()
def _seed(owner_flat, centres, r2):
    # Several centres in one voxel: the largest ball contains the others.
    for i in range(centres.size):
        o = owner_flat[centres[i]]
        if o < 0 or r2[i] > r2[o]:
            owner_flat[centres[i]] = i


@njit()
def _envelope_line(own, p1, p2, sites, axis, b1, b2, g, v, z, out_own, out_pow):
    """Upper envelope of the parabolas ``g_q - (x - q)^2`` of one line (eq. 7.26 squared).

    ``own[q]`` is the ball owning site ``q`` (-1: no site); ``sites[o] = (r^2, cx, cy, cz)``
    gives its value ``g_q = r^2 - |p_q - c_o|^2``, with ``(p1, p2)`` the line's
    coordinates on axes ``b1``, ``b2``. Felzenszwalb-Huttenlocher on ``-g``.
    """
    n = own.size
    k = -1
    for q in range(n):
        o = own[q]
        if o < 0:
            continue
        d2 = (q - sites[o, 1 + axis]) ** 2 + (p1 - sites[o, 1 + b1]) ** 2 + (p2 - sites[o, 1 + b2]) ** 2
        g[q] = sites[o, 0] - d2
        if k < 0:
            k = 0
            v[0] = q
            z[0] = -np.inf
            z[1] = np.inf
            continue
        # The parabola of q overtakes that of v[k] at num / den; z[0] = -inf stops the pops.
        while True:
            p = v[k]
            num = (g[p] - p * p) - (g[q] - q * q)
            den = 2.0 * (q - p)
            if num <= z[k] * den:
                k -= 1
            else:
                break
        k += 1
        v[k] = q
        z[k] = num / den
        z[k + 1] = np.inf
    if k < 0:
        out_own[:] = -1
        out_pow[:] = -np.inf
        return
    k = 0
    for q in range(n):
        while z[k + 1] < q:
            k += 1
        p = v[k]
        out_own[q] = own[p]
        out_pow[q] = g[p] - (q - p) ** 2


@njit(parallel=True)
def _envelope_pass(owner, power, sites, axis):
    """One pass of `_envelope_line` over every line along ``axis``.

    Lines are processed in tiles of ``B`` neighbours along the last free axis,
    so that strided passes read and write whole cache lines. An empty
    ``power`` is not written (the owner alone carries the envelope).
    """
    B = 16
    nx, ny, nz = owner.shape
    n = owner.shape[axis]
    b1 = 1 if axis == 0 else 0
    b2 = 1 if axis == 2 else 2
    s = (ny * nz, nz, 1)
    sa, s1, s2 = s[axis], s[b1], s[b2]
    m2 = owner.shape[b2]
    own_flat = owner.reshape(-1)
    pow_flat = power.reshape(-1)
    with_power = pow_flat.size > 0
    for i1 in prange(owner.shape[b1]):
        g = np.empty(n, np.float64)
        v = np.empty(n, np.int64)
        z = np.empty(n + 1, np.float64)
        tile = np.empty((B, n), np.int32)
        tile_own = np.empty((B, n), np.int32)
        tile_pow = np.empty((B, n), np.float32)
        for t0 in range(0, m2, B):
            nb = min(B, m2 - t0)
            base = i1 * s1 + t0 * s2
            for q in range(n):
                for b in range(nb):
                    tile[b, q] = own_flat[base + q * sa + b * s2]
            for b in range(nb):
                _envelope_line(tile[b], i1, t0 + b, sites, axis, b1, b2, g, v, z, tile_own[b], tile_pow[b])
            for q in range(n):
                for b in range(nb):
                    own_flat[base + q * sa + b * s2] = tile_own[b, q]
                    if with_power:
                        pow_flat[base + q * sa + b * s2] = tile_pow[b, q]


@njit(parallel=True)
def _relabel(owner, label):
    flat = owner.reshape(-1)
    for i in prange(flat.size):
        flat[i] = label[flat[i]]


def reverse_edt(shape, centres, radii):
    """Power of the union of balls and the ball that attains it (eq. 7.26, squared form).

    Parameters
    ----------
    shape : tuple of 3 int
        Shape ``(nx, ny, nz)`` of the volume.
    centres : (n,) array of int64
        Flat indices of the ball centres.
    radii : (n,) array of float
        Ball radii in voxels (``D(y)`` in eq. 7.26), finite and >= 0; squared
        radii within rounding of an integer are snapped to it (`squared_radii`).

    Returns
    -------
    power : (nx, ny, nz) float32 array
        ``max_i (radii[i]^2 - |x - c_i|^2)``, positive exactly inside the union
        of the open balls; ``-inf`` everywhere when ``n == 0``.
    owner : (nx, ny, nz) int32 array
        The maximising ``i`` (an index into ``centres``), ``-1`` when ``n == 0``.

    Notes
    -----
    Three separable passes (axis 0, 1, 2) of the upper envelope of parabolas,
    each linear in the number of voxels (Coeurjolly & Montanvert's REDT, §7.4).
    Ties between balls go to either; ``power`` does not depend on the choice.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §7.4, eq. 7.26-7.27.
    .. [2] P. F. Felzenszwalb, D. P. Huttenlocher, "Distance transforms of sampled functions",
           Theory of Computing 8, 2012.
    """
    shape, centres, radii = _validate(shape, centres, radii)
    power = np.full(shape, -np.inf, dtype=np.float32)
    return power, _owner(shape, centres, squared_radii(radii), power)


def _owner(shape, centres, r2, power):
    """The three envelope passes; the owner as an index into ``centres`` (``power`` as in `_envelope_pass`)."""
    owner = np.full(shape, -1, dtype=np.int32)
    if centres.size == 0:
        return owner
    # Sorted centres keep each pass's look-ups of ball data local in memory.
    order = np.argsort(centres, kind="stable")
    sites = np.empty((centres.size, 4))
    sites[:, 0] = r2[order]
    sites[:, 1:] = unravel(centres[order], shape)
    _seed(owner.reshape(-1), centres[order], sites[:, 0].copy())
    for axis in range(3):
        _envelope_pass(owner, power, sites, axis)
    _relabel(owner, order.astype(np.int32))
    return owner


def union_of_balls(shape, centres, radii):
    """The reconstruction (eq. 7.27) and its field, without the power volume.

    Same as ``reconstruction(reverse_edt(...)[0])`` and `signed_distance` of
    the owner, in 5 bytes per voxel: the field is written over the owner's
    buffer, voxel by voxel.

    Returns
    -------
    mask : (nx, ny, nz) bool array
        Voxels strictly inside the union of the open balls.
    field : (nx, ny, nz) float32 array
        `signed_distance` of the union (``-inf`` everywhere when there is no ball).
    """
    shape, centres, radii = _validate(shape, centres, radii)
    r2 = squared_radii(radii)
    owner = _owner(shape, centres, r2, np.empty((0, 0, 0), np.float32))
    field = owner.view(np.float32)
    _signed_distance(owner, unravel(centres, shape), r2, field)
    return field > 0, field


def naive_union_of_balls(shape, centres, radii):
    """The union of the open balls by splatting each one (eq. 7.25): the baseline of Fig. 7.6.

    Every ball visits its bounding box, so the time grows with the sum of the balls' volumes, where
    `union_of_balls` is linear in the grid; the two give the same voxels.

    Returns
    -------
    (nx, ny, nz) bool array
        Voxels strictly inside the union of the open balls ``|x - c_i| < radii[i]``.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §7.4, eq. 7.25, Fig. 7.6.
    """
    shape, centres, radii = _validate(shape, centres, radii)
    mask = np.zeros(shape, dtype=np.bool_)
    _splat(mask, unravel(centres, shape), squared_radii(radii))
    return mask


@njit()
def _splat(mask, coords, r2):
    nx, ny, nz = mask.shape
    for n in range(coords.shape[0]):
        reach = int(np.ceil(np.sqrt(r2[n])))
        x, y, z = coords[n, 0], coords[n, 1], coords[n, 2]
        for i in range(max(x - reach, 0), min(x + reach + 1, nx)):
            for j in range(max(y - reach, 0), min(y + reach + 1, ny)):
                for k in range(max(z - reach, 0), min(z + reach + 1, nz)):
                    if (i - x) ** 2 + (j - y) ** 2 + (k - z) ** 2 < r2[n]:
                        mask[i, j, k] = True


def reconstruction(power):
    """The reconstructed shape, eq. 7.27: voxels where the power is strictly positive.

    Parameters
    ----------
    power : ndarray
        Output of `reverse_edt`.

    Returns
    -------
    ndarray of bool
        The union of the open balls ``|x - c_i| < radii[i]``.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §2.2.4, eq. 2.7; §7.4.
    """
    return np.asarray(power) > 0


@njit(parallel=True)
def _signed_distance(owner, coords, r2, out):
    nx, ny, nz = owner.shape
    for i in prange(nx):
        for j in range(ny):
            for k in range(nz):
                o = owner[i, j, k]  # read before out[i, j, k] is written: out may share owner's buffer
                if o < 0:
                    out[i, j, k] = -np.inf
                    continue
                d2 = float((i - coords[o, 0]) ** 2 + (j - coords[o, 1]) ** 2 + (k - coords[o, 2]) ** 2)
                den = np.sqrt(r2[o]) + np.sqrt(d2)
                # (r^2 - d^2) / (r + d) = r - d, with the sign of r^2 - d^2 exactly as in the power.
                out[i, j, k] = (r2[o] - d2) / den if den > 0 else 0.0


def signed_distance(shape, centres, radii, owner):
    """Continuous inside/outside field of the union of balls, for sub-voxel surfaces.

    Parameters
    ----------
    shape : tuple of 3 int
        Shape of the volume.
    centres, radii : (n,) arrays
        As given to `reverse_edt`.
    owner : (nx, ny, nz) int array
        The ``owner`` returned by `reverse_edt`.

    Returns
    -------
    (nx, ny, nz) float32 array
        ``Phi(x) = r_o - |x - c_o|`` with ``o = owner[x]`` and ``r_o`` the (snapped)
        radius: the eq. 7.26 term of the power-maximising ball. It has the sign
        of the power everywhere, is 0 exactly where the power is 0, and
        ``Phi <= max_i (r_i - |x - c_i|)`` (eq. 7.26), with equality for a single
        ball. ``-inf`` where ``owner`` is -1.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §7.4.
    """
    shape, centres, radii = _validate(shape, centres, radii)
    owner = np.ascontiguousarray(owner, dtype=np.int32)
    if owner.shape != shape:
        raise ParameterError(f"owner has shape {owner.shape}, expected {shape}")
    if owner.min() < -1 or owner.max() >= centres.size:
        raise ParameterError("owner must index into centres (or be -1)")
    out = np.empty(shape, dtype=np.float32)
    _signed_distance(owner, unravel(centres, shape), squared_radii(radii), out)
    return out
