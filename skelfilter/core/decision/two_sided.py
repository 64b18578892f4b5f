"""Two-sided noise: whether the input has dents as well as bumps, and where it has, both sides decided
ball by ball against the input's modal reading on its thick parts.

The foreground stage takes the bumps off and leaves the dents, widened by a halo: the pruning rounds
off every dent's rim, a layer as deep as the dent around it, so on noise with dents the default's
surface sinks and ends further from the clean shape than the input. The background stage run after it
fills the dents, but wherever bumps survived it also fills the valleys between them (a mug's whole
inside), and neither stage's noise estimate tells whether an input has dents at all.

1. `read_dents`: whether the input has dents, read from the foreground's result K. K keeps the dents
   (widened) and loses the bumps, so it is the input's concave side: closed by a ball of `DENT_CLOSING`
   voxels, it fills its dents and, along their length only, the shape's real concavities. The fill
   counted per voxel of K's surface (the *pitted depth*) is at least `PITTED_DEPTH` on inputs with
   dents, under it on clean inputs and on bumps alone.
2. `decide_both_sides`: where it is, each skeleton ball of the input, on both sides of the surface, is
   decided by the input's modal reading (`modal_reading`): a foreground ball centred outside it is a
   bump's, a background ball centred inside it a dent's, and the voxels they own
   (`skelfilter.core.ball_owners`) change side. The modal reading starts from the majority reading
   (`majority_reading`: a voxel is in where most of the `MAJORITY_WINDOW`-wide cube around it is, the
   sign of the median of the input's signed distance over the cube), which the noise moves by up to its
   own height where dents or bumps cluster, and moves it to the height most of the input's surface sits
   at nearby (a trimmed local mean): not the bumps' tops, not the dents' floors. A window rounds off thin
   parts and narrow concavities as well as noise, so the decision replaces K only near the thick parts
   of both sides of the majority reading, and not at the feet of the thin parts or the mouths of the
   slots that stand out of them (`trusted_parts`); there it fills the dents, gives back the halos the
   pruning took around them and takes the bumps K kept, but of K only what an opening of the input by
   a ball of `BUMP_RADIUS` takes (the shape's edges, which a window rounds, stay).

Measured on the quality benchmark's shapes (docs/design/noise-estimate.md, "Both sides decided by the
majority reading" and "The modal reading").
"""

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from skelfilter.core import ball_owners
from skelfilter.core.decision.feature_restore import ball_closing, ball_opening
from skelfilter.core.distance import distance_transform
from skelfilter.core.neighbourhood import CUBE, bounding_box, surface_voxels

# Voxels: the ball that closes the foreground's result. It fills the thesis' dents (about 2 voxels
# across, as deep) with the halo around them; a concave edge or a mug's inside it fills along their
# length only, a small share of the surface.
DENT_CLOSING = 4.0
# Voxels filled per voxel of the foreground result's surface from which the input has dents: inputs with
# dents read 0.80 or more, without (clean shapes, bumps alone) 0.75 at most, on every benchmark shape at
# 128 and 160 voxels.
PITTED_DEPTH = 0.77
# Voxels: the cube of the majority reading. Over it the bumps and dents, a minority of the surface, do
# not move the majority; a wider one rounds off more of the shape's edges.
MAJORITY_WINDOW = 15
# Voxels around the reading's thick parts (those a ball of half the window fits in) where the decision holds.
THICK_MARGIN = 4.0
# Voxels: the Gaussian over which the modal reading averages the surface's heights, and the band around
# the running average within which a surface voxel counts (a thesis bump stands 3 voxels, so its top and a
# dent's floor fall outside it once the average is near the clean surface).
MODAL_SIGMA = 4.0
MODAL_BAND = 1.0
# Trimmed averages after the first, plain one.
MODAL_ROUNDS = 4
# Voxels: the furthest the modal reading moves from the majority reading.
MODAL_REACH = 6.0
# Voxels: a part of the foreground's result standing further than this out of the thick parts is a thin
# part (a leg, a fin, a rim), not a bump's top (the thesis' bumps stand 3 voxels), and the decision keeps
# off its foot, within `FOOT_REACH` of it, so that it is not cut from the body.
THIN_PART_HEIGHT = 4.0
FOOT_REACH = THICK_MARGIN + 1.0
# Voxels: the decision takes from the foreground's result only what an opening by this ball takes from
# the input (the thesis' bumps are 2.1 voxels in radius; a right-angled edge loses a sliver).
BUMP_RADIUS = 3.5


@dataclass
class DentReading:
    """What `read_dents` read on the foreground's result, and what `decide_both_sides` changed.

    Attributes
    ----------
    depth : float
        Voxels the closing by `DENT_CLOSING` fills per voxel of the result's surface.
    found : bool
        ``depth >= PITTED_DEPTH``: the input has dents, both sides are decided.
    changed : int
        Voxels the two-sided decision changed (0 where it did not run).
    """

    depth: float
    found: bool
    changed: int = 0

    def describe(self):
        """One line a user can read."""
        if not self.found:
            return f"dents: none read (the result is pitted {self.depth:.2f} voxels deep, dents from {PITTED_DEPTH:g})"
        return (f"dents: the result is pitted {self.depth:.2f} voxels deep: both sides decided by the input's "
                f"modal reading, {self.changed} voxels changed")


def read_dents(kept):
    """Whether the input has dents, read from the foreground's result ``kept`` (see the module's
    docstring): a `DentReading`.

    Examples
    --------
    >>> import numpy as np
    >>> box = np.zeros((40, 40, 40), bool); box[8:32, 8:32, 8:32] = True
    >>> read_dents(box).found
    False
    >>> pitted = box.copy()
    >>> for x in range(9, 31, 3):
    ...     for y in range(9, 31, 3):
    ...         pitted[x, y, 29:32] = False                 # dents 3 voxels deep all over the top
    >>> read_dents(pitted).depth > read_dents(box).depth
    True
    """
    box = bounding_box(kept)
    if box is None:
        return DentReading(depth=0.0, found=False)
    # The grid's outside counts as the complement for the closing and the erosion alike, so the box of
    # the set gives the same counts as the whole grid.
    kept = kept[box]
    filled = np.count_nonzero(ball_closing(kept, DENT_CLOSING) & ~kept)
    surface = np.count_nonzero(surface_voxels(kept))
    depth = filled / surface
    return DentReading(depth=float(depth), found=bool(depth >= PITTED_DEPTH))


def majority_reading(volume, window=MAJORITY_WINDOW):
    """The voxels where more than half of the ``window``-wide cube around them is in ``volume`` (the
    grid's outside counts as out): the sign of the median of the signed distance over the cube."""
    return ndimage.uniform_filter(volume.astype(np.float32), window, mode="constant") > 0.5


def modal_reading(volume, window=MAJORITY_WINDOW, sigma=MODAL_SIGMA, band=MODAL_BAND):
    r"""The input's modal surface: the majority reading moved to the height most of ``volume``'s surface
    sits at nearby.

    Let :math:`d` be the signed distance to the majority reading's surface (voxels, negative inside,
    measured from the surface between the voxels) and :math:`S` the surface voxels of ``volume``, each at
    height :math:`s = d + 1/2` (its outer face). The height field is a Gaussian-weighted mean of the
    heights, taken again `MODAL_ROUNDS` times over only the surface voxels within ``band`` of it:

    .. math:: h_{k+1} = \frac{G_\sigma * (s\,w_k)}{G_\sigma * w_k},\qquad
              w_k = [x \in S]\,[\,|s - h_k| < \text{band}\,]

    (:math:`w_0 = [x \in S]`), a trimmed mean that settles on the local mode of the heights. The reading is
    :math:`d < h` (:math:`h` clipped to `MODAL_REACH`; 0 far from every surface voxel).

    Parameters
    ----------
    volume : bool ndarray
        The input; the grid's outside counts as out.
    window : int, optional
        Voxels: the majority reading's cube.
    sigma, band : float, optional
        Voxels: the Gaussian of the local mean and the band around it within which a surface voxel counts.

    Returns
    -------
    bool ndarray
        The reading (empty where the majority reading is).

    Examples
    --------
    >>> import numpy as np
    >>> box = np.zeros((64, 64, 64), bool); box[12:52, 12:52, 12:52] = True
    >>> bumpy = box.copy(); bumpy[24:27, 24:27, 52:55] = True; bumpy[36:39, 36:39, 49:52] = False
    >>> reading = modal_reading(bumpy)
    >>> bool(reading[25, 25, 52]), bool(reading[37, 37, 51])    # the bump's foot out, the dent's floor in
    (False, True)
    >>> int((reading ^ box).sum()) < int((majority_reading(bumpy) ^ box).sum())   # the edges rounded less
    True
    """
    return _modal_from(volume, majority_reading(volume, window), sigma, band)


def _modal_from(volume, majority, sigma=MODAL_SIGMA, band=MODAL_BAND):
    """`modal_reading` of ``volume`` from its majority reading ``majority``."""
    if not majority.any():
        return majority
    distance = distance_transform(~majority).astype(np.float32)
    distance -= distance_transform(majority)
    # From the voxels' centres to the surface between them: the majority reading's own surface at 0.
    distance -= 0.5 * np.sign(distance)
    surface = surface_voxels(volume).astype(np.float32)
    level = distance + 0.5  # a surface voxel's height: its outer face
    heights = level * surface

    def local_mean(weights):
        total = ndimage.gaussian_filter(weights, sigma)
        return ndimage.gaussian_filter(heights * weights, sigma) / np.maximum(total, 1e-6), total

    height, total = local_mean(surface)
    for _ in range(MODAL_ROUNDS):
        height, total = local_mean(surface * (np.abs(level - height) < band))
    height = np.clip(np.where(total > 1e-3, height, 0.0), -MODAL_REACH, MODAL_REACH)
    return distance < height


def thick_parts(reading, window=MAJORITY_WINDOW, margin=THICK_MARGIN):
    """The voxels within ``margin`` voxels of the balls of radius half the window that fit in ``reading``
    (its opening by that ball, widened): where a window's reading is the shape's, not its thin parts
    rounded off."""
    radius = (window - 1) / 2
    inner = distance_transform(reading) > radius
    if not inner.any():
        return inner
    return distance_transform(~inner) <= radius + margin


def decide_both_sides(volume, kept, window=MAJORITY_WINDOW):
    """The two-sided decision (see the module's docstring): ``kept`` with the per-ball decision against
    the modal reading of ``volume`` (its bumps' and dents' balls' voxels changed side, the seams smoothed:
    `ball_owners.seam_smoothed`) in its place where the majority reading is trusted (`trusted_parts`),
    taking from ``kept`` only what an opening of ``volume`` by a ball of `BUMP_RADIUS` takes.

    Parameters
    ----------
    volume : bool ndarray
        The stage's input; its set keeps at least ``window`` voxels from the grid's faces.
    kept : bool ndarray
        The foreground stage's result on it.
    window : int, optional
        Voxels: the majority reading's cube.

    Returns
    -------
    bool ndarray
    """
    majority = majority_reading(volume, window)
    thick = trusted_parts(majority, volume, kept, window)
    if not thick.any():
        return kept.copy()
    reading = _modal_from(volume, majority)
    # Only balls near the surface can be centred across the reading from their side; their voxels lie
    # within a window of it.
    owners = [ball_owners.ray_owners(side, reach=window)
              for side in (volume, ball_owners.bounded_background(volume))]
    flat = reading.reshape(-1)
    decided = ball_owners.owned_output(volume, *owners, ~flat[owners[0][2]], flat[owners[1][2]])
    decided = ball_owners.seam_smoothed(volume, decided)
    # What it takes from the foreground's result, only where the input stands out narrower than a
    # noise-sized ball: the bumps, not the shape's edges, which a window rounds off.
    taken = kept & ~decided & thick & ~ball_opening(volume, BUMP_RADIUS)
    return (kept & ~taken) | (decided & thick)


def trusted_parts(reading, volume, kept, window=MAJORITY_WINDOW):
    """Where the majority reading decides: near the thick parts of both sides of it (`thick_parts` of the
    reading and of its complement), so that neither a thin part nor a narrow concavity (a slot, the gap
    between a gear's teeth) is rounded off, and not within `FOOT_REACH` of where a part of ``kept`` stands
    further than `THIN_PART_HEIGHT` out of the first (a leg's foot) or a part of the complement of
    ``volume`` out of the second (a slot's mouth). The complement of ``kept`` would not do: its dents,
    widened by the halos, stand that far."""
    trusted = None
    for side, result in ((reading, kept), (~reading, ~volume)):
        thick = thick_parts(side, window)
        if not thick.any():
            return thick
        thick &= ~_thin_part_feet(result, thick)
        trusted = thick if trusted is None else trusted & thick
    return trusted


def _thin_part_feet(kept, thick):
    """The voxels within `FOOT_REACH` of the parts of ``kept`` that stand further than `THIN_PART_HEIGHT`
    out of ``thick``: where the thin parts join the body."""
    beyond = kept & ~thick
    if not beyond.any():
        return beyond
    labels, count = ndimage.label(beyond, structure=CUBE)
    height = distance_transform(~thick)
    tallest = ndimage.maximum(height, labels, index=np.arange(1, count + 1))
    tall = np.concatenate(([False], np.asarray(tallest) > THIN_PART_HEIGHT))[labels]
    if not tall.any():
        return tall
    return distance_transform(~tall) <= FOOT_REACH
