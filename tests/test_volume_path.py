"""The volume path's shortcuts give what the whole path gave, bit for bit: the noise estimate on the
smoothed volume decides before its features are kept, and the input's distances are read at the voxels
that keep them only."""

import numpy as np
import pytest
from conftest import data_path
from scipy import ndimage

from skelfilter import add_noise, denoise_volume
from skelfilter.core import pipeline, surface_field, volume_fine_pass
from skelfilter.core import spacing as voxel_spacing
from skelfilter.core.decision import stage_pruning
from skelfilter.runtime.progress import Progress


def test_signed_distance_at_is_the_whole_grids():
    rng = np.random.default_rng(0)
    for trial in range(24):
        shape = tuple(int(n) for n in rng.integers(1 if trial < 6 else 20, 28, 3))
        if trial % 3 == 0:  # thick blobs: distances past NEAREST_REACH, so the whole-grid fallback
            mask = ndimage.gaussian_filter(rng.random(shape), 2) > 0.5
        else:
            mask = rng.random(shape) < rng.random()
        mask[...] = True if trial == 4 else False if trial == 5 else mask
        if trial in (6, 7):  # a thick block, inside or around: far voxels on both sides
            mask[...] = trial == 7
            mask[tuple(slice(n // 8, n - n // 8) for n in shape)] = trial == 6
        indices = rng.choice(mask.size, size=min(mask.size, 300), replace=False)
        whole = voxel_spacing.signed_distance(mask, (1.0, 1.0, 1.0)).reshape(-1)[indices]
        at = surface_field.signed_distance_at(mask, indices)
        assert at.dtype == whole.dtype and np.array_equal(at.view(np.int32), whole.view(np.int32))


def _previous_path(volume):
    """denoise_volume's cubic path as it was: the stages run whole on the smoothed volume, the input's
    signed distance over the whole grid; the mask and field, and which branch ran."""
    progress, params = Progress(enabled=False), pipeline.resolve_params()
    smoothed, _ = volume_fine_pass.fine_pass(volume)
    branch = "no fine noise"
    result, stages_input = pipeline._denoise_cubic(volume, params, progress), volume
    if smoothed is not volume:
        branch = "smoothed passes through"
        result, stages_input = pipeline._denoise_cubic(smoothed, params, progress), smoothed
        if not stage_pruning.passes_through(params, result):
            branch = "input passes through"
            on_input = pipeline._denoise_cubic(volume, params, progress)
            if not stage_pruning.passes_through(params, on_input):
                branch = "on the input"
                result, stages_input = on_input, volume
    input_field = voxel_spacing.signed_distance(stages_input, (1.0, 1.0, 1.0))
    surface_field.keep_input_field(result.field, result.mask, stages_input, input_field)
    return result.mask, result.field, branch


def _noisy_box(seed, bumps):
    rng = np.random.default_rng(seed)
    box = np.zeros((64, 56, 48), dtype=bool)
    box[14:50, 14:42, 14:34] = True
    if bumps:
        box = add_noise(box, p=0.02, r=2.1, h=3, l=4, seed=seed).noisy
    surface = box ^ ndimage.binary_erosion(box)
    flips = surface & (rng.random(box.shape) < 0.3)
    return box ^ flips


def _noisy_fandisk_mesh_voxels():
    """benchmarks/bench_pipeline.py's volume at 128: noise at the skeleton's scale after the fine pass."""
    from skelfilter.io import mesh_files
    from skelfilter.mesh import pipeline as mesh_pipeline
    from skelfilter.params import NoiseParams

    mesh = mesh_files.load_mesh(data_path("fandisk.obj"))
    return mesh_pipeline.noisy_mesh(mesh, NoiseParams(resolution=128, seed=1))[1].noisy


@pytest.mark.parametrize("make, branch", [(lambda: _noisy_box(1, True), "smoothed passes through"),
                                          (lambda: _noisy_box(2, False), "smoothed passes through"),
                                          (_noisy_fandisk_mesh_voxels, "on the input")])
def test_volume_path_as_before(make, branch):
    volume = make()
    box = pipeline._crop(volume)
    mask, field, ran = _previous_path(volume[box])
    result = denoise_volume(volume)
    assert ran == branch
    assert np.array_equal(result.mask[box], mask)
    assert np.array_equal(result.field[box].view(np.int32), field.view(np.int32))
