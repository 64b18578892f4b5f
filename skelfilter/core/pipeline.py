"""The adapted saliency pipeline (thesis §8.1.1) on volumes: composition of the stages.

A stage, on the foreground's set for bumps and then the background's for dents, module by module:
distance & feature fields (`distance`) -> skeleton (`skeleton`) -> importance (`importance`) ->
derivative measure and rho+ (`saliency`) -> the pruning rule and selection (`decision.pruning_rules`,
`decision.selection`, applied by `stage.pruned_stage`) -> EDT filter (`edt_filters`) -> reconstruction
(`reconstruct`) -> noise measured and the pruning at the noise's scale (`decision.noise_estimate`,
`decision.stage_pruning`) -> features given back (`decision.feature_restore`); then specks and
needles (`edt_filters`) and the surface field (`surface_field`). A volume's fine pass
(`volume_fine_pass`) runs before the stages. Meshes go through :mod:`skelfilter.mesh.pipeline`, which
voxelizes them and runs this.
"""

from dataclasses import dataclass, field

import numpy as np

from skelfilter.core import edt_filters, surface_field, volume_fine_pass
from skelfilter.core import spacing as voxel_spacing
from skelfilter.core.decision import feature_restore, noise_handles, stage_pruning, two_sided
from skelfilter.core.distance import distance_transform
from skelfilter.core.neighbourhood import bounding_box, dilated_by_cross
from skelfilter.errors import InputError, ParameterError, ResourceError
from skelfilter.parameter_fields import build, limits_of, with_parameter_entries
from skelfilter.params import DenoiseParams, VolumeParams
from skelfilter.runtime import worker_threads
from skelfilter.runtime.memory import check_grid_fits
from skelfilter.runtime.progress import Progress

# Voxels of the input kept around the set's bounding box where no background stage runs (the default):
# more than the fine pass's widest Gaussian reaches (4 sigma) and half the two-sided decision's majority
# window; the rest of the grid is not looked at.
CROP_MARGIN = 12
# Voxels around those the two-sided decision changed whose field is made again from the mask.
_FIELD_BAND = 2
# Voxels: the field given to a voxel the surface passes through exactly on the way back to the input's
# thick slices, with the sign of the input's voxel.
SURFACE_TIE = 1e-3


@dataclass
class DenoiseResult:
    mask: np.ndarray  # denoised occupancy, same shape as the input volume
    field: np.ndarray  # > 0 inside; its 0-level is the sub-voxel surface
    stages: dict = field(default_factory=dict)  # "foreground"/"background" -> StageResult
    noise: dict = field(default_factory=dict)  # "foreground"/"background" -> noise_estimate.NoiseEstimate
    fine_noise: object = None  # a volume's volume_fine_pass.VoxelRoughness, where the fine pass changed it
    timings: dict = field(default_factory=dict)
    voxels_changed: int = 0  # voxels added or removed: on the voxel grid of a mesh, on a volume's own
    route: object = None  # a mesh's skelfilter.mesh.route.Route: what ran and why
    dents: object = None  # decision.two_sided.DentReading where ``stages`` auto read the input for dents
    noise_handles_closed: int = 0  # tunnels the noise left that `noise_handles` filled


def resolve_params(params=None, **overrides):
    """A DenoiseParams from an instance and/or keyword overrides."""
    return build(DenoiseParams, params, **overrides)


def denoise_padded(volume, params, progress, foreground=None):
    """Both stages on a volume whose set keeps ``params.padding_voxels`` from the faces.

    Each stage's mask and field are consumed by what follows (in place, to
    keep memory low): ``stages`` keeps the first stage's mask and every
    stage's skeleton data. ``foreground``: the (stage, estimate) pair `stage_at_noise_scale` gave on
    this volume with these parameters, where the caller ran it already.
    """
    result = DenoiseResult(mask=volume, field=None, timings=progress.timings)
    current = volume
    if params.stages in ("both", "foreground", "auto"):
        with progress.stage("foreground"):
            if foreground is None:
                foreground = stage_pruning.stage_at_noise_scale(current, params, "bumps", progress)
            stage, estimate = foreground
            if feature_restore.measures_noise(params):
                result.noise["foreground"] = feature_restore.keep_features(current, stage, params, "bumps", progress,
                                                                           estimate)
        result.stages["foreground"] = stage
        current = stage.mask
        field = stage.field
    if not current.any():
        raise InputError(
            f"nothing is left after pruning at threshold t = {params.threshold_voxels:g} voxels: "
            "the whole shape is thinner than the noise scale; lower `threshold` or raise `resolution`"
        )
    if params.stages == "auto":
        with progress.stage("both sides"):
            current, field, result.dents = _both_sides(volume, current, field, progress)
    if params.stages in ("both", "background"):
        field = None
        if "foreground" in result.stages:
            result.stages["foreground"].field = None
        # The background lives inside the box; the box's outer layer stands
        # for the infinite outside so the background set is bounded (eq. 3.4).
        background = ~current
        _fill_outside(background, (slice(1, -1),) * 3, False)
        with progress.stage("background"):
            stage, estimate = stage_pruning.stage_at_noise_scale(background, params, "dents", progress)
            if feature_restore.measures_noise(params):
                result.noise["background"] = feature_restore.keep_features(background, stage, params, "dents",
                                                                           progress, estimate)
        del background
        result.stages["background"] = stage
        # Filling dents never reaches past the shape's bounding box; outside
        # it the background's reconstruction only misses the frame's own
        # edges (cut by the EDT filter), which are not part of the shape.
        box = bounding_box(current)
        current, field = stage.mask, stage.field
        stage.mask = stage.field = None
        np.logical_not(current, out=current)
        _fill_outside(current, box, False)
        np.negative(field, out=field)
        _fill_outside(field, tuple(slice(b.start - 1, b.stop + 1) for b in box), -1.0)
    # A shape in which no stage found noise passes through whole: no specks or spikes taken off either.
    unchanged = stage_pruning.passes_through(params, result)
    if params.edt_filter == "minify" and not unchanged:
        with progress.step("specks"):
            specks = edt_filters.specks(current, params.minify_radius)
            current ^= specks
            field[specks] = np.where(current[specks], 1.0, -1.0)
    if params.thin_radius_voxels is not None and not unchanged:
        with progress.step("needles"):
            spikes = edt_filters.needles(current)
            current &= ~spikes
            field[spikes] = -1.0
    if params.noise_handles == "close" and not unchanged:
        with progress.step("noise handles"):
            tunnels, closed = noise_handles.filled_noise_handles(current)
            current |= tunnels
            field[tunnels] = 1.0
        result.noise_handles_closed = closed
        if closed:
            progress.note(f"noise handles: {closed} {'tunnel' if closed == 1 else 'tunnels'} the noise left closed "
                          f"({np.count_nonzero(tunnels)} voxels filled)")
    # The mesh and the voxels must agree: inside the surface iff in the mask.
    np.maximum(field, 1e-3, out=field, where=current)
    np.minimum(field, -1e-3, out=field, where=~current)
    result.mask = current
    result.field = field
    return result


def _both_sides(volume, kept, field, progress):
    """``stages`` auto after the foreground stage: where its result ``kept`` reads as pitted (the input
    has dents), both sides decided by the input's modal reading (`two_sided`); the field follows
    the voxels that changed. Returns (mask, field, `two_sided.DentReading`)."""
    with progress.step("dents read"):
        reading = two_sided.read_dents(kept)
    if reading.found:
        with progress.step("both sides decided"):
            decided = two_sided.decide_both_sides(volume, kept)
            changed = decided ^ kept
            reading.changed = int(np.count_nonzero(changed))
            if reading.changed:
                box = bounding_box(changed, margin=_FIELD_BAND)
                inside = distance_transform(decided[box]) - surface_field.SURFACE_OFFSET
                outside = surface_field.SURFACE_OFFSET - distance_transform(~decided[box])
                band = dilated_by_cross(changed[box], _FIELD_BAND)
                field[box][band] = np.where(decided[box], inside, outside)[band]
            kept = decided
    progress.note(reading.describe())
    return kept, field, reading


def _fill_outside(volume, box, value):
    """Set every voxel of ``volume`` outside the slices ``box`` to ``value``, in place."""
    for axis, s in enumerate(box):
        start, stop, _ = s.indices(volume.shape[axis])
        for part in (slice(None, start), slice(stop, None)):
            index = [slice(None)] * 3
            index[axis] = part
            volume[tuple(index)] = value


def denoise_volume(volume, params=None, progress=None, spacing=None, affine=None, **overrides):
    """Denoise a binary volume (thesis §8.1.1).

    Parameters
    ----------
    volume : (nx, ny, nz) array_like of bool
        The noisy shape X.
    params : DenoiseParams, optional
        The parameters; the keywords below override its fields (``denoise_volume(v, threshold=12)``;
        a field left unset takes the preset's).
    progress : Progress, optional
        Step timings and the notes that say what was chosen (printed when enabled).
    spacing : sequence of 3 floats, optional
        Voxel size along each axis (e.g. millimetres). Anisotropic voxels are resampled to cubic
        ones of the finest spacing for the pipeline and the result back (:mod:`skelfilter.core.spacing`);
        voxel counts in the parameters are then in voxels of the finest spacing, and a relative
        threshold stands for the same physical size whatever the spacing.
    affine : (4, 4) array_like, optional
        Voxel index to world coordinates (a scanner's volume); gives the spacing (the lengths of its
        columns) when ``spacing`` is not given. `skelfilter.mesh.marching_cubes.field_to_world_mesh`
        (``result.field``, the affine) makes the world-coordinate mesh.

    Returns
    -------
    DenoiseResult
        ``mask`` (same shape as ``volume``), ``field`` (> 0 inside, 0 on the
        sub-voxel surface), per-stage skeleton data (on the cubic grid of the part of the volume the
        pipeline reads: with the foreground stage alone, the set's bounding box widened by
        `CROP_MARGIN` voxels) and step timings.
        The volume's grid is used as it is: ``resolution`` is taken as the longest side of the
        set voxels' bounding box, so a relative threshold is relative to the shape's size. With the
        default, a volume in which no stage finds noise at the skeleton's scale comes back unchanged
        (``noise`` says what each stage found; ``fine_noise`` what the volume fine pass smoothed).

    Examples
    --------
    >>> import numpy as np
    >>> from skelfilter import denoise_volume
    >>> cube = np.zeros((40, 40, 40), dtype=bool)
    >>> cube[8:32, 8:32, 8:32] = True
    >>> result = denoise_volume(cube)
    >>> bool((result.mask == cube).all()), result.noise["foreground"].found
    (True, False)

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §3.1.1 (the two stages), §8.1.1 (the pipeline).
    .. [2] A. Telea, "Feature preserving smoothing of shapes using saliency skeletons",
           Visualization in Medicine and Life Sciences II, Springer, 2012.
    """
    worker_threads.start()
    try:
        return _denoise_volume(volume, params, progress, spacing, affine, overrides)
    except MemoryError:
        raise ResourceError(f"out of memory denoising a volume of shape {np.shape(volume)}; resample it to "
                            "fewer voxels, or free memory") from None


with_parameter_entries(denoise_volume, DenoiseParams)


def _denoise_volume(volume, params, progress, spacing, affine, overrides):
    params = resolve_params(params, **overrides)
    if params.normal_filter != "adaptive":
        raise ParameterError("`normal_filter` is for meshes: a volume's fine pass smooths the mask itself")
    if params.output_mesh != DenoiseParams(preset=params.preset).output_mesh:
        raise ParameterError("`output_mesh` is for mesh inputs (the CLI's --close too): a volume's output is its "
                             "mask, or its marching cubes for a mesh output file")
    volume = np.asarray(volume)
    if volume.ndim != 3:
        raise InputError(f"a volume must be 3-D, got shape {volume.shape}")
    volume = volume.astype(bool)
    if not volume.any():
        raise InputError("the volume is empty: no voxel is set")
    progress = progress or Progress(enabled=False)
    if spacing is None and affine is not None:
        spacing = np.linalg.norm(np.asarray(affine, dtype=float)[:3, :3], axis=0)
    if spacing is not None:
        # as given, one number per entry: the table's check refuses anything but three numbers
        spacing = VolumeParams(spacing=tuple(np.ravel(np.asarray(spacing, dtype=object)).tolist())).spacing
    resample = spacing is not None and not voxel_spacing.is_isotropic(spacing)
    # The background stage's set is bounded by the grid: its skeleton, and so its output, depend on the
    # grid's extent; the foreground's do not, nor the two-sided decision's, which looks only within its
    # window of the surface.
    box = _crop(volume, spacing if resample else None) if params.stages in ("foreground", "auto") else None
    if box is not None and any(b.stop - b.start < n for b, n in zip(box, volume.shape)):
        # A label of a large segmentation: its voxels and their surroundings, not the whole scan.
        result = _denoise_volume(volume[box], params, progress, spacing, None, {})
        mask, field = np.zeros(volume.shape, dtype=bool), np.full(volume.shape, -float(CROP_MARGIN), np.float32)
        mask[box], field[box] = result.mask, result.field
        result.mask, result.field = mask, field
        return result
    keep = params.unchanged_surface == "input"
    if resample:
        cubic_shape = voxel_spacing.isotropic_shape(volume.shape, spacing)
        _check_side(max(cubic_shape), params, spacing)
        check_grid_fits(cubic_shape)
        with progress.step("to cubic voxels"):
            input_field, _ = voxel_spacing.to_isotropic(volume, spacing)
            cubic = input_field > 0
    else:
        cubic = volume
        input_field = None
    result, stages_input = _fine_pass_then_stages(cubic, params, progress, volume if resample else None)
    if keep:
        with progress.step("input surface"):
            if stages_input is not cubic:
                input_field = None  # the stages' input's own distances, at the voxels read
            surface_field.keep_input_field(result.field, result.mask, stages_input, input_field)
    del cubic, input_field, stages_input
    if resample:
        with progress.step("back to the input's voxels"):
            result.field = voxel_spacing.from_isotropic(result.field, spacing, volume.shape)
            # A voxel whose centre the surface passes through (half of it in, half out on the cubic
            # grid: the surface between its two halves) keeps the input's value; all going out would
            # take a quarter slice off every cap (a ball 6 % of its volume at slices twice as thick).
            tie = result.field == 0
            result.field[tie] = np.where(volume[tie], SURFACE_TIE, -SURFACE_TIE)
            result.mask = result.field > 0
    result.voxels_changed = int(np.count_nonzero(result.mask != volume))
    return result


def _crop(volume, spacing=None):
    """The set's bounding box widened by `CROP_MARGIN` voxels. With anisotropic ``spacing`` each
    start is moved down (by at most `CROP_MARGIN` more) to where the cubic grid of the box is part of
    the whole volume's (`spacing.to_isotropic` puts the centres of cubic voxels at the same places),
    so that the output does not depend on the crop."""
    box = bounding_box(volume, margin=CROP_MARGIN)
    if spacing is None:
        return box
    ratio = np.asarray(spacing, dtype=float) / min(spacing)
    aligned = []
    for b, r in zip(box, ratio):
        starts = np.arange(b.start, max(b.start - CROP_MARGIN, 0) - 1, -1)
        offset = starts * r
        fits = np.flatnonzero(np.abs(offset - np.rint(offset)) < 1e-6)
        aligned.append(slice(int(starts[fits[0]]) if len(fits) else b.start, b.stop))
    return tuple(aligned)


def _fine_pass_then_stages(cubic, params, progress, sampled=None):
    """The volume fine pass (`volume_fine_pass.fine_pass`; ``sampled``: the volume on its own grid where
    ``cubic`` is its resampling), then the stages on its result: the DenoiseResult and the volume the
    stages ran on.

    The fine pass is for noise below the skeleton's scale. Where the stages still find noise at the
    skeleton's scale after it, the noise is bumps the fine pass would have merged (it fills the
    valleys between them, and merged bumps are kept): the fine pass is undone and the stages run on
    the input as it was. Where they find nothing on the input (the noise stood on thin parts, which
    the pruning took whole), the result after the fine pass is kept: the input would pass through
    with all its noise. Stages that prune as told (`DenoiseParams.prunes_as_told`)
    run on the input directly.
    """
    _cubic_params(cubic, params)  # too large a grid is refused before the fine pass runs
    if params.fine_pass != "off" and params.prunes_as_told:
        progress.note("fine pass: not run, the stages prune at the skeleton's scale whatever the noise "
                      "(prune as-told)")
    elif params.fine_pass != "off":
        with progress.step("fine pass"):
            smoothed, fine = volume_fine_pass.fine_pass(cubic, sampled)
        progress.note(fine.describe())
        if smoothed is not cubic:
            # The foreground stage's noise estimate alone decides whether the smoothed volume passes
            # through: where it finds noise, the rest of its stages (features kept, specks, needles: a
            # tenth of the volume path) is run only if the input passes through and it is kept.
            foreground = _foreground_first(smoothed, params, progress)
            result = None
            if foreground is None or not foreground[1][1].found:
                result = _denoise_cubic(smoothed, params, progress, foreground)
            if result is None or not stage_pruning.passes_through(params, result):
                progress.note("noise at the skeleton's scale: the fine pass is undone, the stages run on the input")
                on_input = _denoise_cubic(cubic, params, progress)
                if not stage_pruning.passes_through(params, on_input):
                    return on_input, cubic
                # passed through, the input would keep all its noise
                progress.note("no noise at the skeleton's scale on the input: the result after the fine pass is kept")
                if result is None:
                    result = _denoise_cubic(smoothed, params, progress, foreground)
            result.fine_noise = fine
            return result, smoothed
    return _denoise_cubic(cubic, params, progress), cubic


def _cubic_params(volume, params):
    """The parameters for a volume of cubic voxels (its extent as the resolution) and its padding,
    checked to fit in memory."""
    extent = max(s.stop - s.start for s in bounding_box(volume))
    _check_side(extent, params)
    params = params.with_(resolution=max(extent, 16))
    pad = params.padding_voxels
    check_grid_fits(tuple(s + 2 * pad for s in volume.shape), padding=pad, padding_from=padding_from(params))
    return params, pad


def _check_side(voxels, params, spacing=None):
    """Refuse a grid longer than a grid may be (the largest resolution) along an axis."""
    most = limits_of(type(params), "resolution")[1]
    if voxels > most:
        cubic = f" (its {' x '.join(f'{s:g}' for s in spacing)} voxels made cubic)" if spacing is not None else ""
        raise InputError(f"the volume spans {voxels} voxels{cubic}; a grid holds at most {most} along an axis: "
                         "crop the volume, or resample it to coarser voxels")


def _foreground_first(volume, params, progress):
    """The foreground stage of `_denoise_cubic` on ``volume``, ahead of the rest: ``(padded volume,
    (stage, estimate))`` for `_denoise_cubic`'s ``foreground``; None where the stages do not start
    with it (background alone)."""
    if params.stages == "background":
        return None
    params, pad = _cubic_params(volume, params)
    padded = np.pad(volume, pad)
    with progress.stage("foreground"):
        return padded, stage_pruning.stage_at_noise_scale(padded, params, "bumps", progress)


def _denoise_cubic(volume, params, progress, foreground=None):
    """The stages on a non-empty boolean volume of cubic voxels; ``foreground``: `_foreground_first`'s
    result on ``volume``, or None."""
    params, pad = _cubic_params(volume, params)
    padded, first = foreground if foreground is not None else (np.pad(volume, pad), None)
    result = denoise_padded(padded, params, progress, first)
    inner = (slice(pad, -pad),) * 3
    result.mask = np.ascontiguousarray(result.mask[inner])
    result.field = np.ascontiguousarray(result.field[inner])
    return result


def padding_from(params):
    """The parameters that set the padding, for the memory advice."""
    return "`padding`" if params.padding is not None else "`threshold` (half of it pads the grid)"
