"""The decision: which skeleton balls and voxels stay, on both sides of the surface.

In the order a stage takes them (:mod:`skelfilter.core.pipeline` runs a stage per side, the foreground's
set for bumps, the background's for dents):

1. `pruning_rules`: the rule that keeps skeleton voxels by their measures (rho+ >= t, eq. 5.6, the
   default; the thesis' alternatives, eq. 3.1-3.2, 4.4, 5.1-5.3), and `selection`: the root's component,
   the thin parts kept whatever their importance, the detached noise dropped. `skelfilter.core.stage`
   applies them between the skeleton's measures and the reconstruction.
2. `stage_pruning`: the pruning at t, and at finer thresholds where it kept too little of the shape to
   measure the noise against; whether the stages found nothing and give their input back.
3. `noise_estimate`: how high the noise stands and over how much of the surface, measured on what the
   pruning removed.
4. `feature_restore`: what the pruning removed that is no noise, given back (features by their extent,
   the noise on them excepted, cut pieces joined, edge skins).
5. `two_sided` (``stages`` auto): whether the foreground's result reads as pitted (the input has dents),
   and where it does, a per-ball decision on both sides against the input's modal reading in its place
   on the thick parts.

With ``prune`` measured, a stage that finds no noise gives its input back; as told, it prunes at t.
"""
