"""Synthetic surface noise: random bumps and curvilinear stripes (thesis §7.2).

Protrusions are spheres swept along the outward surface normal (eq. 7.13-7.14),
repeated along short random walks on the boundary layer (eq. 7.15-7.16) that
start at randomly drawn incident sites (eq. 7.17). Dents are the same model
applied to the background: they are bumps of the complement, carved away.
"""

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from skelfilter.core.neighbourhood import OFFSETS_26, STEP_LENGTHS_26, ball_offsets, flat_offsets, ravel, unravel
from skelfilter.errors import InputError, ParameterError

# Radius of the neighbourhood of the least-squares normal fit.
NORMAL_RADIUS = 3.0
# Internal padding: the normal fit must never index outside the volume.
_PAD = int(NORMAL_RADIUS) + 1
# (segments x kernel offsets) pairs rasterized at once.
_CHUNK_PAIRS = 1 << 20


@dataclass(frozen=True)
class NoiseResult:
    """A clean volume, its noisy version and what changed between them."""

    clean: np.ndarray
    noisy: np.ndarray
    bumps: np.ndarray
    dents: np.ndarray
    sites: np.ndarray


def add_noise(clean, p=0.014, r=2.1, h=3, l=6, seed=0, dents=False):
    """Add the thesis' synthetic surface noise to a voxel volume.

    Each voxel of the boundary layer ``M = (X ⊕ b) \\ X`` (eq. 7.12) is an
    incident site with probability ``p``. From every site a random walk of
    ``l`` voxels on ``M`` keeps roughly to a random tangent direction
    (eq. 7.15), and at each walk voxel ``a`` an open sphere of radius ``r`` is
    swept from ``a`` to ``a + h n`` along the outward normal ``n``
    (eq. 7.13-7.14). The noisy volume is ``X`` united with all these
    protrusions (eq. 7.16-7.17).

    Parameters
    ----------
    clean : (nx, ny, nz) array_like of bool
        The volume ``X``.
    p : float
        Incidence: probability that a surface voxel starts a protrusion.
    r : float
        Radius of the spherical kernel, in voxels.
    h : float
        Height of a protrusion along the normal, in voxels.
    l : int
        Number of voxels of each walk; ``l = 1`` gives isolated bumps (0D noise).
    seed : int
        Seed of ``numpy.random.default_rng``; equal seeds give identical results.
    dents : bool
        Also carve dents: the same model applied to the background (sites on
        the inner boundary layer ``X \\ (X ⊖ b)``, spheres swept inward), drawn
        independently after the bumps and removed after the bumps are added.

    Returns
    -------
    NoiseResult
        ``clean``, ``noisy``, ``bumps = noisy & ~clean``,
        ``dents = clean & ~noisy`` and the ``(n, 3)`` voxel coordinates of the
        incident sites, bump sites first.

    Raises
    ------
    ParameterError
        For ``p`` outside [0, 1], ``r <= 0``, ``h < 0`` or ``l`` not an integer >= 1, and when a
        protrusion would reach within 1 voxel of the volume's border (pad the
        volume by at least ``h + r + 2`` voxels).
    InputError
        When ``clean`` is not a 3-D volume.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §7.2, eq. 7.12-7.17.
    """
    if not 0 <= p <= 1:
        raise ParameterError(f"p must be in [0, 1], got {p}")
    if not (r > 0 and h >= 0 and l >= 1 and l == int(l)):
        raise ParameterError(f"noise needs r > 0, h >= 0 and an integer l >= 1, got r={r}, h={h}, l={l}")
    x = np.asarray(clean, dtype=bool)
    if x.ndim != 3:
        raise InputError(f"noise needs a 3-D volume, got shape {x.shape}")

    rng = np.random.default_rng(seed)
    solid = np.pad(x, _PAD)
    noisy = np.array(x, order="C")
    bump_sites, swept = _sweep(solid, p, r, h, int(l), rng, x.shape)
    noisy.reshape(-1)[swept] = True  # eq. 7.17
    sites = [bump_sites]
    if dents:
        dent_sites, carved = _sweep(~solid, p, r, h, int(l), rng, x.shape)
        noisy.reshape(-1)[carved] = False
        sites.append(dent_sites)
    sites = unravel(np.concatenate(sites), solid.shape) - _PAD
    return NoiseResult(clean=x, noisy=noisy, bumps=noisy & ~x, dents=x & ~noisy, sites=sites)


def _sweep(solid, p, r, h, l, rng, shape):
    """Incident sites on ``solid``'s outer boundary layer and the voxels their protrusions cover.

    ``solid`` is padded by ``_PAD``; sites are flat indices into it, covered
    voxels flat indices (possibly repeated) into the unpadded volume of ``shape``.
    """
    layer = ndimage.maximum_filter(solid, size=3) & ~solid  # eq. 7.12
    candidates = np.flatnonzero(layer)
    sites = candidates[rng.random(candidates.size) < p]
    walks, normals = _walk(sites, layer.reshape(-1), solid.reshape(-1), solid.shape, l, rng)
    walks, first = np.unique(walks, return_index=True)  # eq. 7.16: a union over the walks' voxels
    return sites, _capsules(unravel(walks, solid.shape) - _PAD, normals[first], r, h, shape)


def _walk(sites, layer, solid, shape, l, rng):
    """Voxels and outward normals of the random walks from ``sites`` (eq. 7.15).

    Each walk keeps to a tangent direction ``d``, drawn uniformly per site and
    carried along by projecting it on the tangent plane of every voxel it visits.
    """
    d = rng.standard_normal((sites.size, 3))
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    at = sites
    voxels, normals = [], []
    for k in range(l):
        n = _normals(at, layer, solid, shape)
        voxels.append(at)
        normals.append(n)
        d = _project_tangent(d, n)
        if k < l - 1:
            at = _step(at, d, layer, shape, rng)
    return np.concatenate(voxels), np.concatenate(normals)


def _step(at, d, layer, shape, rng):
    """One step of every walk to a 26-neighbour on ``layer``, preferring those ahead along ``d``.

    Neighbours with a positive component along ``d`` are drawn with probability
    proportional to that component; without any, every neighbour on the layer
    is equally likely (eq. 7.15 as printed); with no neighbour at all the walk stays.
    """
    neighbours = at[:, None] + flat_offsets(shape, OFFSETS_26)
    on_layer = layer[neighbours]
    ahead = d @ (OFFSETS_26 / STEP_LENGTHS_26[:, None]).T
    weight = np.where(on_layer & (ahead > 1e-9), ahead, 0.0)  # eq. 7.15, directed
    weight = np.where(weight.any(axis=1, keepdims=True), weight, on_layer)
    cumulative = np.cumsum(weight, axis=1)
    pick = (cumulative <= rng.random(at.size)[:, None] * cumulative[:, -1:]).sum(axis=1)
    pick = np.minimum(pick, len(OFFSETS_26) - 1)
    return np.where(cumulative[:, -1] > 0, neighbours[np.arange(at.size), pick], at)


def _normals(at, layer, solid, shape):
    """Outward unit normals at voxels of the boundary layer ``layer``.

    The normal is the least-squares plane normal (smallest principal axis) of
    the layer voxels within ``NORMAL_RADIUS``, oriented away from the centroid
    of the solid voxels there, i.e. along decreasing occupancy.
    """
    offsets, _ = ball_offsets(NORMAL_RADIUS)
    around = at[:, None] + flat_offsets(shape, offsets)
    weight = layer[around].astype(np.float64)
    count = weight.sum(axis=1)[:, None]
    mean = weight @ offsets / count
    second = weight @ (offsets[:, :, None] * offsets[:, None, :]).reshape(-1, 9) / count
    covariance = second.reshape(-1, 3, 3) - mean[:, :, None] * mean[:, None, :]
    n = np.linalg.eigh(covariance)[1][:, :, 0]
    inward = solid[around].astype(np.float64) @ offsets
    return np.where(((n * inward).sum(axis=1) > 0)[:, None], -n, n)


def _project_tangent(d, n):
    """``d`` projected on the planes orthogonal to ``n``, kept where the projection degenerates."""
    t = d - (d * n).sum(axis=1, keepdims=True) * n
    norm = np.linalg.norm(t, axis=1, keepdims=True)
    return np.where(norm > 1e-6, t / np.maximum(norm, 1e-12), d)


def _capsules(starts, normals, r, h, shape):
    """Flat indices of the voxels within ``r`` of a segment ``[a, a + h n]`` (eq. 7.13-7.14).

    The union of the open spheres ``|y - (a + h' n)| < r`` over all ``h'`` in
    ``[0, h]`` is the open capsule of radius ``r`` around the segment.
    Raises ``ParameterError`` when one of its voxels lies within 1 voxel of the border.
    """
    base = np.rint(starts + 0.5 * h * normals).astype(np.int64)
    offsets, _ = ball_offsets(0.5 * h + r + np.sqrt(3) / 2)
    real = offsets.astype(np.float64)
    lengths2 = (real**2).sum(axis=1)
    limit = np.array(shape) - 2
    chunk = max(1, _CHUNK_PAIRS // len(offsets))
    covered = [np.empty(0, np.int64)]
    for start in range(0, len(starts), chunk):
        part = slice(start, start + chunk)
        n = normals[part]
        shift = (base[part] - starts[part]).astype(np.float64)
        # q = shift + o is a voxel relative to a; its distance to the segment via |q|^2 and q.n.
        qn = (shift * n).sum(axis=1, keepdims=True) + n @ real.T
        q2 = (shift**2).sum(axis=1, keepdims=True) + 2 * shift @ real.T + lengths2
        along = np.clip(qn, 0.0, h)
        centre, k = np.nonzero(q2 - 2 * along * qn + along**2 < r * r)
        voxels = base[start + centre] + offsets[k]
        if voxels.size and (voxels.min() < 1 or (voxels > limit).any()):
            raise ParameterError(
                "noise protrusions reach within 1 voxel of the volume border; "
                "pad the volume by at least h + r + 2 voxels"
            )
        covered.append(ravel(voxels, shape))
    return np.concatenate(covered)
