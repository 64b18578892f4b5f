"""What a pruning removed that is no noise, given back: features by their extent, and connections.

Pruning decides voxel by voxel from the skeleton's importance, so a part thinner than the threshold
goes with the noise whatever its length: a wing, a leg, a fin, a rim. Noise is low (see
:mod:`skelfilter.core.decision.noise_estimate`); a removed part that stands higher above the kept shape than the
noise is a feature, and comes back: what of it a straight run of the shape longer than the noise
passes through, so that the noise standing on a leg or a wing stays removed. And a pruning that cuts
a shape in two, or cuts a piece of it loose, removed what joined them: that comes back too.
"""

import numpy as np
from scipy import ndimage

from skelfilter.core.decision import noise_estimate
from skelfilter.core.decision.noise_estimate import height_above
from skelfilter.core.distance import distance_transform
from skelfilter.core.line_opening import line_opening
from skelfilter.core.neighbourhood import CUBE, OFFSETS_26, bounding_box, dilated_by_cube, flat_offsets, push
from skelfilter.runtime.compiled import njit

# Voxels added to the estimated noise height before a removed part counts as a feature: the
# estimate is a 99 % quantile of the noise's peaks, and the tallest noise blobs pass it by a voxel or
# two (measured on the tuning shapes of benchmarks/quality.py, see docs/design/noise-estimate.md).
MARGIN = 2.0
# Voxels from the nearest tall removed voxel beyond which a removed skin is an edge's, not noise's
# (bumps' feet reach about r = 2 voxels around them; 2, 3 and 4 were measured).
SKIN_REACH = 3.0
# A restored feature keeps the voxels that a straight run of the shape this many noise heights long
# passes through (`along_lines`), the runs found on the shape closed by a ball of `DENT_FILL` voxels.
RUN_PER_HEIGHT = 1.75
DENT_FILL = 3.0


def features_by_extent(stage_set, pruned, height, tolerance=0.5):
    """The removed voxels of the parts that stand higher than ``height`` above the pruned shape.

    The removed voxels (``stage_set`` \\ ``pruned``) farther than ``height`` from ``pruned`` are the
    tops of features. From them the feature is followed down to where it joins the kept shape:
    through 26-neighbours among the removed voxels on paths whose height (distance to ``pruned``)
    never rises more than ``tolerance`` above the lowest height on the way, so a feature comes back
    whole while the noise next to its foot, which rises again, stays removed.

    Parameters
    ----------
    stage_set, pruned : bool ndarray
        The stage's set X and its pruned reconstruction K ⊆ X.
    height : float
        Voxels: the noise height; parts standing higher are features.
    tolerance : float, optional
        Voxels: how much a path down a feature may rise above its lowest point (the grid's
        quantization of distances).

    Returns
    -------
    bool ndarray, the shape of ``stage_set``

    Examples
    --------
    >>> import numpy as np
    >>> body = np.zeros((30, 30, 60), bool); body[5:25, 5:25, 5:25] = True
    >>> leg = body.copy(); leg[14:16, 14:16, 25:50] = True         # a 2-voxel rod, 25 long
    >>> int(features_by_extent(leg, body, 6.0).sum())
    100
    """
    removed = stage_set & ~pruned
    out = np.zeros_like(removed)
    box, above = height_above(removed, pruned, height + 2.0)
    if box is None:
        return out
    tops = np.flatnonzero((above > height).reshape(-1))
    if not tops.size:
        return out
    # Padded by one voxel so that no neighbour step leaves the array.
    tops = np.unravel_index(tops, above.shape)
    above = np.pad(above, 1)
    found = np.zeros(above.shape, dtype=bool)
    tops = np.ravel_multi_index(tuple(c + 1 for c in tops), above.shape)
    # Beyond the reach of height_above every height reads as the reach: a flat top, followed freely.
    _descend(above.reshape(-1), found.reshape(-1), tops, flat_offsets(above.shape, OFFSETS_26), tolerance)
    out[box] = found[1:-1, 1:-1, 1:-1]
    return out


def along_lines(stage_set, restored, height):
    """The voxels of ``restored`` through which a straight run at least `RUN_PER_HEIGHT` ``* height``
    voxels long passes, in one of 13 directions, in ``stage_set`` closed by a ball of `DENT_FILL`.

    A feature that stands higher than the noise comes back from `features_by_extent` whole, with the
    noise that stands on it. A leg, a slat, a wing or a rim holds long straight runs along itself, and
    a short part standing on a deep body holds them through the body; a blob of noise on a thin part
    is no longer than the noise in any direction, and goes (`line_opening.line_opening`). The closing
    fills the dents narrower than the ball, which would cut the runs of a thin wall or leg apart; it
    adds no voxel to the output, which is a part of ``restored``.

    Examples
    --------
    >>> import numpy as np
    >>> body = np.zeros((30, 30, 60), bool); body[5:25, 5:25, 5:25] = True
    >>> leg = body.copy(); leg[14:16, 14:16, 25:50] = True         # a 2-voxel rod, 25 long
    >>> noisy = leg.copy(); noisy[16:19, 14:17, 40:43] = True       # a blob on it
    >>> restored = features_by_extent(noisy, body, 6.0)
    >>> int(restored.sum()), int(along_lines(noisy, restored, 6.0).sum())
    (127, 100)
    """
    out = np.zeros_like(restored)
    length = int(np.ceil(RUN_PER_HEIGHT * height))
    # A run through a restored voxel lies within ``length`` of it, and the closing there reads the
    # set within two radii.
    box = bounding_box(restored, margin=length + 2 * int(np.ceil(DENT_FILL)) + 1)
    if box is None:
        return out
    out[box] = restored[box] & line_opening(ball_closing(stage_set[box], DENT_FILL), length)
    return out


def ball_closing(volume, radius):
    """``volume`` closed by a ball of ``radius`` voxels (Euclidean): the voxels that no ball of that
    radius lying in the complement covers. The grid's outside counts as the complement."""
    pad = int(np.ceil(radius)) + 1
    grown = distance_transform(np.pad(~volume, pad, constant_values=True)) <= radius
    return (distance_transform(grown) > radius)[pad:-pad, pad:-pad, pad:-pad]


def ball_opening(volume, radius):
    """``volume`` opened by a ball of ``radius`` voxels (Euclidean): the union of the balls of that radius
    that fit in it (the grid's outside counts as the complement)."""
    centres = distance_transform(volume) > radius
    if not centres.any():
        return centres
    return distance_transform(~centres) <= radius


@njit()
def _descend(height, found, seeds, steps, tolerance):
    """Mark (in ``found``) the voxels of height > 0 reached from ``seeds`` through 26-neighbours on a
    path that never rises more than ``tolerance`` above its lowest voxel so far.

    Each voxel keeps the highest such lowest level over the paths found to it (label correcting:
    a voxel is visited again when a path with a higher level reaches it).
    """
    level = np.full(height.size, -1.0, dtype=np.float32)
    stack = np.empty(max(seeds.size, 1024), dtype=np.int64)
    top = 0
    for s in seeds:
        if level[s] < height[s]:
            level[s] = height[s]
            stack, top = push(stack, top, s)
    while top > 0:
        top -= 1
        v = stack[top]
        for step in steps:
            u = v + step
            if height[u] <= 0.0 or height[u] > level[v] + tolerance:
                continue
            new = min(level[v], height[u])
            if new <= level[u]:
                continue
            level[u] = new
            stack, top = push(stack, top, u)
    for v in range(height.size):
        found[v] = level[v] >= 0.0


def connections(stage_set, result, width, most=8):
    """Removed voxels that join pieces of ``result`` which ``stage_set`` had joined.

    Each piece (26-connected) of ``result`` but the largest is joined to the piece nearest to it
    through the removed voxels ``stage_set \\ result``: with ``g`` the least ``d_A + d_B`` over the
    removed voxels (``d`` the distances to the two pieces, found with one distance transform per
    piece), the bridge is the removed voxels with ``d_A + d_B <= g + 2 max(g, width)``, a neck about
    ``width`` across, where it joins both pieces. So the result keeps the input's components (the
    noise could not have split them) without giving back all the noise around the neck. Only the
    ``most`` largest pieces are joined (the smaller ones are specks, removed later).

    Returns
    -------
    bool ndarray
        The voxels to restore.
    """
    removed = stage_set & ~result
    out = np.zeros_like(removed)
    box = bounding_box(stage_set, margin=1)
    if box is None or not removed.any():
        return out
    kept, n_kept = ndimage.label(result[box], structure=CUBE)
    if n_kept <= 1:
        return out
    sizes = np.bincount(kept.reshape(-1))[1:]
    order = np.argsort(-sizes)[:most] + 1
    gone = removed[box]
    distance = {label: distance_transform(kept != label) for label in order}
    bridges = np.zeros_like(gone)
    for i, a in enumerate(order[1:], 1):
        gaps = [(float((distance[a] + distance[b])[gone].min()), b) for b in order[:i]]
        gap, b = min(gaps)
        total = distance[a] + distance[b]
        neck = gone & (total <= gap + 2 * max(gap, width))
        # The part of the neck that touches both pieces.
        labels, _ = ndimage.label(neck, structure=CUBE)
        near_a = dilated_by_cube(kept == a)
        near_b = dilated_by_cube(kept == b)
        both = np.intersect1d(labels[near_a & neck], labels[near_b & neck])
        bridges |= np.isin(labels, both[both > 0])
    out[box] = bridges
    return out


def skin_far_from_noise(stage_set, pruned, reach):
    """Removed voxels farther than ``reach`` from every removed voxel standing 2 voxels or more above
    ``pruned``: the skin that the pruning and the minification take off convex edges and corners
    (a voxel or two), away from any noise, comes back.

    A voxel stands 2 or more above ``pruned`` when none of its 26 neighbours is in it: every other
    voxel lies at least 2 away (the neighbours at 1, √2 and √3), so the cube's dilation tells the
    heights' distance transform's answer.

    Returns
    -------
    bool ndarray
        The voxels to restore.
    """
    removed = stage_set & ~pruned
    out = np.zeros_like(removed)
    box = bounding_box(removed, margin=1)  # every removed voxel's 26 neighbours in it
    if box is None:
        return out
    noise = removed[box] & ~dilated_by_cube(pruned[box])
    if not noise.any():
        out[box] = removed[box]
        return out
    out[box] = removed[box] & (distance_transform(~noise) > reach)
    return out


def keep_features(stage_set, stage, params, side, progress, estimate=None):
    """Give back what the pruning of ``stage_set`` removed that is no noise, in ``stage`` (in place).

    The noise is measured on what the pruning removed (`noise_estimate.estimate_noise`; ``estimate``
    where the caller measured it already), unless ``params.noise_height`` gives its height. Removed
    parts standing higher than the noise (with `MARGIN`) come back (`features_by_extent`) but for the
    noise on them, which no straight run of the shape longer than the noise passes through
    (`along_lines`); and so do whatever joined pieces that the pruning cut apart (`connections`) and the
    skin of edges away from the noise (`skin_far_from_noise`). With ``keep_features`` off nothing
    comes back. Where no noise is found and ``prune`` is measured, everything comes back: the input
    passes through. Returns the `noise_estimate.NoiseEstimate`, also told through ``progress``.
    """
    if estimate is None:
        with progress.step("noise estimate"):
            estimate = noise_estimate.estimate_noise(stage_set, stage.mask, params.resolution, side)
    height = _restored_height(params, estimate)
    given = f"; removed parts standing over {height:g} voxels (the noise height given) come back" \
        if params.noise_height is not None and height is not None else ""
    progress.note(f"noise: {estimate.describe()}{given}")
    with progress.step("features kept"):
        if height is None:
            restored = stage_set & ~stage.mask
        elif params.keep_features == "off":
            return estimate
        else:
            restored = features_by_extent(stage_set, stage.mask, height)
            restored = along_lines(stage_set, restored, height)
            restored |= connections(stage_set, stage.mask | restored, height)
            restored |= skin_far_from_noise(stage_set, stage.mask | restored, SKIN_REACH)
        _restore(stage.mask, stage.field, restored)
    return estimate


def measures_noise(params):
    """Whether a stage's noise is measured after its pruning (`keep_features`): to give back what is no
    noise, or (``prune`` measured) to tell whether there is any."""
    return params.keep_features == "on" or not params.prunes_as_told


def _restored_height(params, estimate):
    """Voxels: the height from which a removed part is a feature, or None where the stage passes its
    input through (``prune`` measured, and no noise found)."""
    if not estimate.found and not params.prunes_as_told:
        return None
    if params.noise_height is not None:
        return params.noise_height
    if estimate.found:
        return estimate.height + MARGIN
    return noise_estimate.HIGHEST_NOISE * params.resolution


def _restore(mask, field, restored):
    """Add ``restored`` to the reconstruction ``mask`` and its ``field`` (in place): inside at half a
    voxel from the surface, which lies on the voxels' faces as for every voxel of the input."""
    box = bounding_box(restored, margin=1)
    if box is None:
        return
    mask |= restored
    np.maximum(field, 0.5, out=field, where=restored)
    rim = dilated_by_cube(restored[box]) & ~mask[box]
    np.maximum(field[box], -0.5, out=field[box], where=rim)
