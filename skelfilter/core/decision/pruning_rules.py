"""The pruning rules: which skeleton voxels a stage keeps (thesis §8.1.1 step 4), one registry.

Each rule is a `PruningRule` in `RULES`, named as the ``pruning`` parameter names it, and declares
what it reads: the derivative measure ``sigma_bar`` (eq. 4.2-4.3, up to the geodesic search cap or
everywhere), whether its selection is reduced to the root's connected component (``Gamma_y``,
eq. 2.3), and whether its measure reads ``rho`` itself (then the geodesic searches go further, see
`search_cap`). `pruned_stage` (:mod:`skelfilter.core.stage`) and the kernel warm-up read only these
declarations, so a new rule is a function and an entry here.

References
----------
.. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
       thesis, University of Groningen, 2016, §3.1.1, §4.2, §5.2.
"""

from dataclasses import dataclass

import numpy as np

from skelfilter.core import saliency
from skelfilter.core.decision import selection
from skelfilter.presets import PRESETS, RHO_RULE_CAP_FACTOR

DERIVATIVE_NONE, DERIVATIVE_CAPPED, DERIVATIVE_FULL = "none", "capped", "full"


@dataclass
class SkeletonMeasures:
    """What a rule reads, per skeleton voxel (flat arrays aligned with ``voxels``)."""

    voxels: np.ndarray  # flat indices into the stage's grid
    shape: tuple  # the stage's grid
    rho: np.ndarray  # importance (eq. 3.6)
    radius: np.ndarray  # D
    sigma_bar: np.ndarray  # derivative measure, NaN where undefined or not read
    velocity: np.ndarray  # v of the derivative measure (None when not read)
    adjacency: tuple  # the skeleton's 26-neighbour graph (CSR)
    cap: float  # the geodesic search cap: rho at it stands for a larger one


@dataclass(frozen=True)
class PruningRule:
    """A pruning rule: ``select(measures, params)`` gives the selected voxels and rho+ (NaN where the
    rule has none)."""

    select: object  # (SkeletonMeasures, params) -> (selected voxels, rho+)
    derivative: str  # DERIVATIVE_NONE, _CAPPED (sigma_bar below the search cap only) or _FULL
    rooted: bool  # the selection is reduced to the root's component Gamma_y (eq. 2.3)
    reads_rho: bool  # the measure reads rho itself: searches go to RHO_RULE_CAP_FACTOR * t


def _no_rho_plus(measures):
    return np.full(len(measures.voxels), np.nan, dtype=np.float32)


def _global(m, params):
    """Threshold t on the global streamline importance rho+ (eq. 5.6, §5.2.2); with ``rho_plus_from``
    'ahead', rho+ comes from the neighbours within the cone along v that the derivative measure steps
    in (the streamlines of eq. 5.1)."""
    ahead = params.rho_plus_from == "ahead"
    rho_plus = saliency.rho_plus(m.rho, m.sigma_bar, m.adjacency, params.k, velocity=m.velocity if ahead else None,
                                 skeleton=m.voxels, shape=m.shape, min_cosine=saliency.STREAM_COSINE,
                                 min_rho=params.derivative_min_rho)
    return rho_plus >= params.threshold_voxels, rho_plus


def _direct(m, params):
    """Threshold t on rho+ of the direct streamlines (eq. 5.1-5.3, §5.2.1)."""
    rho_plus = saliency.direct_rho_plus(m.rho, m.sigma_bar, m.adjacency, m.velocity, m.voxels, m.shape, params.k)
    return rho_plus >= params.threshold_voxels, rho_plus


def _derivative(m, params):
    """rho >= t and not ligature (eq. 4.4); an undefined sigma_bar is never ligature."""
    return (m.rho >= params.threshold_voxels) & ~(m.sigma_bar <= params.k), _no_rho_plus(m)


def _saliency(m, params):
    """Saliency rho / D >= c (eq. 3.1-3.2, Telea's rule); rho at the search cap stands for a larger one."""
    selected = (selection.saliency_measure(m.rho, m.radius) >= params.saliency_threshold) | (m.rho >= m.cap)
    return selected, _no_rho_plus(m)


RULES = {
    "global": PruningRule(_global, DERIVATIVE_FULL, rooted=False, reads_rho=False),
    "direct": PruningRule(_direct, DERIVATIVE_FULL, rooted=False, reads_rho=False),
    "derivative": PruningRule(_derivative, DERIVATIVE_CAPPED, rooted=True, reads_rho=True),
    "saliency": PruningRule(_saliency, DERIVATIVE_NONE, rooted=True, reads_rho=True),
}


def search_cap(params):
    """Length in voxels at which the geodesic searches stop (the ``geodesic_cap`` parameter, or the
    rule's and the preset's default): rules reading rho itself search to 4 t, the streamline rules to
    the preset's factor of t, at least t + 8."""
    if params.geodesic_cap is not None:
        return float(params.geodesic_cap)
    t = params.threshold_voxels
    if RULES[params.pruning].reads_rho:
        return RHO_RULE_CAP_FACTOR * t
    return max(PRESETS[params.preset]["cap_factor"] * t, t + 8.0)


def kept_voxels(measures, params, joined):
    """The skeleton voxels the rule ``params.pruning`` keeps, and rho+ (NaN where it has none).

    ``joined()`` marks the voxels whose feature points lie on one boundary component: the candidates
    for a rooted rule's root (`selection.root_component`); it is called only for those rules.
    """
    rule = RULES[params.pruning]
    selected, rho_plus = rule.select(measures, params)
    if rule.rooted:
        selected = selection.root_component(selected, measures.adjacency, measures.rho, measures.radius,
                                            candidates=joined())
    return selected, rho_plus
