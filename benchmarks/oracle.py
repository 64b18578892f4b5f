"""The per-ball oracle: the output of a skeleton pipeline that knew, ball by ball, which balls are noise
(the clean shape decides): the ceiling of a per-ball decision, which the quality benchmark reports
beside skelfilter's variants (``python -m benchmarks.quality --oracle``).

- `oracle`: the foreground balls whose centre lies inside the clean shape, their radii capped at the
  clean distance, united with the noisy shape's background voxels that no such background ball
  (centre outside the clean shape, radius capped likewise) covers. No stage order, one formulation for
  bumps and dents.
- `owned_oracle`: each voxel decided by the ball that owns it (the ball tangent at its nearest boundary
  point, `skelfilter.core.ball_owners.ray_owners`): the noisy shape less the voxels owned by foreground
  balls centred outside the clean shape, plus the background voxels owned by background balls centred
  inside it. No radius is capped and no voxel that no dropped ball owns changes, so it has no coverage
  gaps. The quality benchmark reports it seam smoothed (`skelfilter.core.ball_owners.seam_smoothed`),
  so that the output's genus can equal the clean shape's.

The experiments that measure what a pipeline's measures tell of the oracle's labels are in
``experiments/ball_oracle.py``.
"""

import numpy as np
from scipy import ndimage

from skelfilter.core import skeleton
from skelfilter.core.ball_owners import bounded_background, owned_output, ray_owners
from skelfilter.core.distance import distance_and_features
from skelfilter.core.reconstruct import union_of_balls

PROTRUSION = 1.0  # voxels a ball may stand beyond the clean shape and still be labelled keep


def labelled_balls(noisy_side, clean_side):
    """The IE-skeleton balls of ``noisy_side``: (flat centres, radii, clean radii, noise labels)."""
    distance, _ = distance_and_features(noisy_side)
    centres = skeleton.ie_skeleton(distance)
    radii = distance.reshape(-1)[centres].astype(np.float64)
    clean_distance = ndimage.distance_transform_edt(clean_side).reshape(-1)[centres]
    return centres, radii, clean_distance, radii - clean_distance > PROTRUSION


def oracle(noisy, clean):
    """The oracle's output mask (see the module's docstring) and the foreground's labelled balls."""
    shape = noisy.shape
    fg = labelled_balls(noisy, clean)
    bg = labelled_balls(bounded_background(noisy), bounded_background(clean))

    def kept_union(centres, radii, clean_radii):
        inside = clean_radii > 0  # the centre lies in the clean set of its side
        if not inside.any():
            return np.zeros(shape, dtype=bool)
        return union_of_balls(shape, centres[inside], np.minimum(radii, clean_radii)[inside])[0]

    out = kept_union(*fg[:3]) | (~noisy & ~kept_union(*bg[:3]))
    out[[0, -1], :, :] = out[:, [0, -1], :] = out[:, :, [0, -1]] = False
    return out, fg


def owned_oracle(noisy, clean):
    """`owned_output` with the oracle's drops: the balls centred outside the clean shape (its
    complement's, for the background)."""
    fg, bg = ray_owners(noisy), ray_owners(bounded_background(noisy))
    clean_fg = ndimage.distance_transform_edt(clean).reshape(-1)
    clean_bg = ndimage.distance_transform_edt(bounded_background(clean)).reshape(-1)
    return owned_output(noisy, fg, bg, clean_fg[fg[2]] <= 0, clean_bg[bg[2]] <= 0)
