"""The thesis' error measures on voxel sets and geodesic estimates (eq. 4.17, 4.18, 6.5, 7.23, 7.24).

Voxel-set measures take either flat indices into a C-ordered volume (the convention of
`skelfilter.core.neighbourhood`) or boolean volumes; both arguments must refer to volumes of the
same shape.
"""

import numpy as np

from skelfilter.errors import ParameterError


def _as_flat(voxels):
    """Sorted unique flat indices of a voxel set given as flat indices or a boolean volume."""
    a = np.asarray(voxels)
    if a.dtype == bool:
        return np.flatnonzero(a.reshape(-1)).astype(np.int64)
    if a.size and not np.issubdtype(a.dtype, np.integer):
        raise ParameterError(f"a voxel set must be flat integer indices or a boolean volume, got dtype {a.dtype}")
    return np.unique(a.reshape(-1).astype(np.int64))


def _jaccard_error(a, b):
    a, b = _as_flat(a), _as_flat(b)
    union = np.union1d(a, b).size
    if union == 0:
        return float("nan")
    return 1.0 - np.intersect1d(a, b, assume_unique=True).size / union


def skeleton_error(regularized, original):
    """Total skeleton error ``epsilon`` (thesis eq. 4.17).

    .. math:: \\epsilon = 1 - |S_{v(t)} \\cap S| / |S_{v(t)} \\cup S|

    Parameters
    ----------
    regularized : array_like
        ``S_{v(t)}``: flat int indices or a boolean volume.
    original : array_like
        ``S``: flat int indices or a boolean volume of the same shape.

    Returns
    -------
    float
        In [0, 1]; NaN when both sets are empty (0 / 0).
    """
    return _jaccard_error(regularized, original)


def skeleton_false_positive_rate(regularized, original):
    """False-positive rate ``nu`` of a regularized skeleton (thesis eq. 4.18).

    .. math:: \\nu = |S_{v(t)} \\setminus S| / |S_{v(t)}|

    Parameters
    ----------
    regularized : array_like
        ``S_{v(t)}``: flat int indices or a boolean volume.
    original : array_like
        ``S``: flat int indices or a boolean volume of the same shape.

    Returns
    -------
    float
        In [0, 1]; NaN when ``regularized`` is empty (0 / 0).
    """
    a, b = _as_flat(regularized), _as_flat(original)
    if a.size == 0:
        return float("nan")
    return np.setdiff1d(a, b, assume_unique=True).size / a.size


def reconstruction_error(reconstruction, original):
    """Reconstruction error ``epsilon_hat`` (thesis eq. 6.5, corrected).

    .. math:: \\hat\\epsilon = 1 - |R(S_{v(t)}) \\cap X| / |R(S_{v(t)}) \\cup X|

    As printed, eq. 6.5 has ``|S_{v(t)} \\cup X|`` in the denominator; the
    text calls it eq. 4.17 applied to reconstructions, so the union is taken
    with the reconstruction ``R(S_{v(t)})`` (see READING-NOTES.md).

    Parameters
    ----------
    reconstruction : array_like
        ``R(S_{v(t)})``: flat int indices or a boolean volume.
    original : array_like
        ``X``, the clean model: flat int indices or a boolean volume of the same shape.

    Returns
    -------
    float
        In [0, 1]; NaN when both sets are empty.
    """
    return _jaccard_error(reconstruction, original)




def geodesic_errors(rho, rho_est):
    """Mean and maximum relative error of a geodesic estimate (thesis eq. 7.23, 7.24).

    .. math::
        \\epsilon = \\frac{1}{|S|} \\sum_{x \\in S} \\frac{|\\rho(x) - \\rho_{est}(x)|}{\\rho(x)},
        \\qquad
        m = \\max_{x \\in S} \\frac{|\\rho(x) - \\rho_{est}(x)|}{\\rho(x)}

    Parameters
    ----------
    rho : array_like of float
        Ground-truth (graph) geodesic lengths over the skeleton ``S``; all > 0.
    rho_est : array_like of float
        Estimated lengths, aligned with ``rho``.

    Returns
    -------
    epsilon : float
        Mean relative error (eq. 7.23); NaN for an empty skeleton.
    m : float
        Maximum relative error (eq. 7.24); NaN for an empty skeleton.

    Raises
    ------
    ParameterError
        If the shapes differ, or ``rho`` has values that are not finite and positive.
    """
    rho = np.asarray(rho, dtype=np.float64).reshape(-1)
    est = np.asarray(rho_est, dtype=np.float64).reshape(-1)
    if rho.shape != est.shape:
        raise ParameterError(f"rho and rho_est must have the same size, got {rho.size} and {est.size}")
    if rho.size == 0:
        return float("nan"), float("nan")
    if not (np.isfinite(rho).all() and (rho > 0).all()):
        raise ParameterError("rho must be finite and > 0 (it divides the errors)")
    rel = np.abs(rho - est) / rho
    return float(rel.mean()), float(rel.max())
