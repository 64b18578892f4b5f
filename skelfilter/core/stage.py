"""One stage of the adapted saliency pipeline (thesis §8.1.1 steps 1-5) on a set of voxels.

`skeleton_fields` computes what the pruning reads (distance transform, skeleton, feature points,
importance); `pruned_stage` prunes, filters the radii and reconstructs; `run_stage` is both. The
split lets an experiment prune one skeleton under several rules without recomputing its importance.
"""

from dataclasses import dataclass, replace
from functools import partial

import numpy as np

from skelfilter.core import edt_filters, importance, reconstruct, saliency, skeleton, surface_field, unified
from skelfilter.core.decision import pruning_rules, selection
from skelfilter.core.distance import distance_and_features
from skelfilter.core.neighbourhood import unravel


@dataclass
class SkeletonData:
    """Per-skeleton-voxel quantities of one stage (flat arrays aligned with ``voxels``)."""

    voxels: np.ndarray  # flat indices into the stage's volume
    distance: np.ndarray  # D
    rho: np.ndarray  # importance
    sigma_bar: np.ndarray  # derivative measure (NaN: undefined, eq. 4.3, or not used by the rule)
    rho_plus: np.ndarray  # streamline importance, eq. 5.6 or 5.3 (NaN for the rules of eq. 3.2 and 4.4)
    kept: np.ndarray  # the pruning rule's selection
    radii: np.ndarray  # reconstruction radii of the kept voxels (after the EDT filter)
    expansions: np.ndarray = None  # A* nodes settled per geodesic query


@dataclass
class StageResult:
    mask: np.ndarray  # the reconstruction, a subset of the stage's input set
    field: np.ndarray  # signed distance-like field, > 0 inside the reconstruction
    skeleton: SkeletonData


@dataclass
class SkeletonFields:
    """What a stage's pruning reads (§8.1.1 steps 1-3), handed to `pruned_stage`."""

    distance: np.ndarray  # D over the stage's grid
    voxels: np.ndarray  # flat indices of the skeleton voxels
    a_flat: np.ndarray  # flat indices of their two feature points
    b_flat: np.ndarray
    adjacency: tuple  # the skeleton's 26-neighbour graph (CSR)
    rho: np.ndarray  # importance
    expansions: np.ndarray = None  # A* nodes settled per geodesic query

    def take(self):
        """The arrays, handed over: the object is emptied, so that each array is freed when its
        step is done (`pruned_stage` takes them; a caller that reuses the fields passes a copy)."""
        arrays = (self.distance, self.voxels, self.a_flat, self.b_flat, self.adjacency, self.rho, self.expansions)
        self.distance = self.voxels = self.a_flat = self.b_flat = self.adjacency = self.rho = self.expansions = None
        return arrays

    def copy(self):
        """A copy sharing the arrays, for one `pruned_stage` of several."""
        return replace(self)


def run_stage(volume, params, progress):
    """One stage (§8.1.1 steps 1–5) on the set ``volume``; returns its reconstruction."""
    return pruned_stage(volume, skeleton_fields(volume, params, progress), params, progress)


def skeleton_fields(volume, params, progress):
    """Distance transform, skeleton, feature points and importance of the set ``volume`` (§8.1.1 steps 1-3)."""
    shape = volume.shape
    with progress.step("distance transform"):
        distance, features = distance_and_features(volume)
    with progress.step("skeleton"):
        if params.skeleton == "ie":
            voxels = skeleton.ie_skeleton(distance)
        elif params.skeleton == "ima":
            voxels = skeleton.ima_skeleton(volume, features)
        else:
            voxels = unified.usm_skeleton(volume, params.usm_smoothing, params.usm_min_density)
        a_flat, b_flat = skeleton.extended_feature_points(volume, features, voxels)
        del features
        adjacency = saliency.skeleton_adjacency(voxels, shape)
    with progress.step("importance"):
        expansions = None
        if params.importance == "geodesic":
            rho, expansions = importance.geodesic_importance(
                importance.boundary_layer(volume), a_flat, b_flat, pruning_rules.search_cap(params)
            )
        else:
            if params.importance == "estimate":
                rho = importance.geodesic_estimate(distance, a_flat, b_flat)
            else:
                rho = importance.euclidean_importance(shape, a_flat, b_flat)
            # Feature points on separate surfaces (object and frame) are
            # infinitely far apart along the boundary, whatever the proxy says.
            far = importance.disconnected_pairs(importance.boundary_layer(volume), a_flat, b_flat)
            rho[far] = np.float32(pruning_rules.search_cap(params))
    return SkeletonFields(distance, voxels, a_flat, b_flat, adjacency, rho, expansions)


def pruned_stage(volume, fields, params, progress):
    """Pruning, EDT filter and reconstruction (§8.1.1 steps 4-5) of the skeleton ``fields`` of the set
    ``volume``, which it takes (see `SkeletonFields.take`); returns the stage's reconstruction."""
    shape = volume.shape
    distance, voxels, a_flat, b_flat, adjacency, rho, expansions = fields.take()
    radius = distance.reshape(-1)[voxels]
    rule = pruning_rules.RULES[params.pruning]
    cap = float(np.float32(pruning_rules.search_cap(params)))  # rho is float32: the value the searches were given
    sigma_bar = np.full(len(voxels), np.nan, dtype=np.float32)
    v = None
    if rule.derivative != pruning_rules.DERIVATIVE_NONE:
        with progress.step("derivative measure"):
            v = _velocity(params, volume, distance, voxels, a_flat, b_flat, rho)
            sigma_bar = saliency.derivative_measure(
                rho, distance, voxels, v, adjacency, params.derivative_guard,
                min_cosine=saliency.STREAM_COSINE, min_rho=params.derivative_min_rho,
                max_rho=cap if rule.derivative == pruning_rules.DERIVATIVE_CAPPED else np.inf,
            )
    with progress.step("pruning"):
        measures = pruning_rules.SkeletonMeasures(voxels, shape, rho, radius, sigma_bar, v, adjacency, cap)
        kept, rho_plus = pruning_rules.kept_voxels(measures, params, joined=partial(_joined, volume, a_flat, b_flat))
        del measures
        if params.thin_radius_voxels is not None:
            kept |= selection.thin_part(voxels, a_flat, b_flat, radius, shape, params.thin_radius_voxels)
            kept &= ~selection.detached_noise(kept, adjacency, radius, params.thin_radius_voxels)
        centres = voxels[kept]
        pruned_features = None
        if params.edt_filter == "flat":
            pruned_features = (unravel(a_flat[~kept], shape), unravel(b_flat[~kept], shape))
        del adjacency, a_flat, b_flat
    with progress.step("EDT filter"):
        radii = edt_filters.filtered_radii(params.edt_filter, distance, centres, params.minify_radius,
                                           pruned_features)
        del pruned_features
        # Balls of radius D reach the centres of the nearest outside voxels;
        # shrunk by half a voxel they end on the voxel boundary, so the
        # reconstruction is the voxel set whose centres lie inside the
        # union, and ripples under half a voxel vanish.
        radii = np.maximum(radii - surface_field.SURFACE_OFFSET, 0.0)
    data = SkeletonData(
        voxels=voxels,
        distance=distance.reshape(-1)[voxels],
        rho=rho,
        sigma_bar=sigma_bar,
        rho_plus=rho_plus,
        kept=kept,
        radii=radii,
        expansions=expansions,
    )
    del distance
    with progress.step("reconstruction"):
        mask, phi = reconstruct.union_of_balls(shape, centres, radii)
        # A filter that raised a radius above D must not add to the shape (eq. 6.1, Lemma 7); balls no
        # larger than D - 1/2 hold no voxel of the complement, so this changes nothing for the others.
        outside = mask & ~volume
        mask &= volume
        np.minimum(phi, -1e-3, out=phi, where=outside)
        del outside
    return StageResult(mask=mask, field=phi, skeleton=data)


def _joined(volume, a_flat, b_flat):
    """Skeleton voxels whose two feature points lie on one boundary component."""
    return ~importance.disconnected_pairs(importance.boundary_layer(volume), a_flat, b_flat)


def _velocity(params, volume, distance, voxels, a_flat, b_flat, rho):
    """The velocity field ``v`` of the derivative measure at the skeleton voxels (§4.2.1)."""
    shape = volume.shape
    if params.velocity == "feature":
        return saliency.feature_velocity(voxels, shape, unravel(a_flat, shape), unravel(b_flat, shape))
    if params.velocity == "edt-gradient":
        return saliency.edt_gradient_velocity(distance, voxels)
    if params.velocity == "unified":
        return unified.contraction_direction(volume, params.usm_smoothing, voxels)
    return saliency.importance_gradient_velocity(rho, voxels, shape)


