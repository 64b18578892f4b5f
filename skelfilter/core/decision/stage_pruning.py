"""Each stage's pruning at the noise's scale, and whether the stages gave their input back.

`stage_at_noise_scale` prunes a stage's skeleton at t (`skelfilter.core.stage`), measures the noise on
what the pruning removed (`noise_estimate`), and where the pruning kept too little of the shape to
measure the noise against, prunes again at finer thresholds; `passes_through` says whether the stages
found nothing and gave their input back.
"""

import numpy as np

from skelfilter.core.decision import noise_estimate, pruning_rules
from skelfilter.core.stage import pruned_stage, run_stage, skeleton_fields

# A pruning that keeps less of its set than this, and finds no noise on what it removed, was too coarse
# for the shape (thin legs, a seat, a wing): every removed part stands taller than noise above the little
# that is left. The stage then prunes its skeleton again at t divided by each of FINER_THRESHOLDS in turn.
LEAST_KEPT = 0.25
FINER_THRESHOLDS = (2, 4)


def stage_at_noise_scale(stage_set, params, side, progress):
    """One stage on ``stage_set`` (`stage.run_stage`), its skeleton pruned at finer thresholds
    where the pruning at t leaves too little to measure noise against; returns the `StageResult` and
    the noise estimate of its pruning (``side``: ``"bumps"`` or ``"dents"``; None where the stage
    prunes as told).

    With ``prune`` measured (`DenoiseParams.prunes_as_told` false), a pruning that keeps under
    `LEAST_KEPT` of the set and finds no noise on what it removed (`noise_estimate.estimate_noise`) is
    done again on the same skeleton and importance at t / 2, then
    t / 4 (`FINER_THRESHOLDS`). On a chair or a stool the pruning at t keeps a few percent (the seat's
    core): every leg and slat then stands higher than noise above it, none of the bumps on them is
    counted, and the input passed through whole with its noise. The finer pruning keeps the legs' and
    seat's cores, so the bumps on them are measured and taken off; a clean thin shape finds no noise at
    the finer thresholds either and passes through as before.
    """
    if params.prunes_as_told:
        return run_stage(stage_set, params, progress), None
    def measured(stage):
        with progress.step("noise estimate"):
            return noise_estimate.estimate_noise(stage_set, stage.mask, params.resolution, side)

    fields = skeleton_fields(stage_set, params, progress)
    stage = pruned_stage(stage_set, fields.copy(), params, progress)
    size, threshold, cap = np.count_nonzero(stage_set), params.threshold_voxels, pruning_rules.search_cap(params)
    if np.count_nonzero(stage.mask) >= LEAST_KEPT * size:
        fields = None  # no finer pruning can follow: the skeleton's arrays go before the noise is measured
    estimate = measured(stage)
    for divisor in FINER_THRESHOLDS:
        kept = np.count_nonzero(stage.mask)
        if kept >= LEAST_KEPT * size or estimate.found:
            break
        progress.note(f"the pruning at t = {threshold:g} voxels kept {kept / size:.0%} of the set and found no "
                      f"noise on what it removed: pruned again at t / {divisor}")
        threshold = params.threshold_voxels / divisor
        # the importance was searched to the cap of t: the finer pruning reads it as it is
        finer = params.with_(threshold=threshold, threshold_relative=None, geodesic_cap=cap)
        stage = pruned_stage(stage_set, fields.copy(), finer, progress)
        estimate = measured(stage)
    return stage, estimate


def passes_through(params, result):
    """Whether the stages gave their input back: ``prune`` measured, no stage found noise, and the
    two-sided decision (`two_sided.decide_both_sides`) changed nothing."""
    decided = result.dents is not None and result.dents.changed > 0
    return not params.prunes_as_told and not decided and not any(e.found for e in result.noise.values())
