"""The fine pass of a volume: clean masks pass through, segmentation-like noise goes, thin parts stay."""

import numpy as np
import pytest
from scipy import ndimage

from skelfilter.core import pipeline, volume_fine_pass
from skelfilter.errors import ParameterError
from skelfilter.evaluation import metrics
from skelfilter.params import DenoiseParams


def signed_distance(mask):
    inside = ndimage.distance_transform_edt(mask) - 0.5
    return np.where(mask, inside, -(ndimage.distance_transform_edt(~mask) - 0.5))


def segmentation_noise(mask, amplitude, seed=1):
    """The clean signed distance plus a smooth random field (what a noisy image thresholded gives)."""
    field = ndimage.gaussian_filter(np.random.default_rng(seed).standard_normal(mask.shape), 1.0)
    return signed_distance(mask) + field * (amplitude / field.std()) > 0


def block_with_plate(n=64):
    """A block with a plate 3 voxels thick standing 20 voxels out of it, and a sphere."""
    mask = np.zeros((n, n, n), bool)
    mask[10:34, 10:54, 10:54] = True
    mask[34:54, 20:44, 30:33] = True
    z, y, x = np.ogrid[:n, :n, :n]
    mask |= (z - 22) ** 2 + (y - 32) ** 2 + (x - 32) ** 2 < 14 ** 2
    return mask


def error(out, clean):
    return np.count_nonzero(out ^ clean)


@pytest.mark.parametrize("shape", ["box", "ball", "plate"])
def test_a_clean_mask_passes_through(shape):
    n = 48
    mask = np.zeros((n, n, n), bool)
    z, y, x = np.ogrid[:n, :n, :n]
    if shape == "box":
        mask[8:40, 10:38, 12:36] = True
    elif shape == "ball":
        mask = (z - 24) ** 2 + (y - 24) ** 2 + (x - 24) ** 2 < 17.3 ** 2
    else:
        mask = block_with_plate(n + 16)
    out, noise = volume_fine_pass.fine_pass(mask)
    assert not noise.found and out is mask
    assert "none found" in noise.describe()


def test_segmentation_noise_is_smoothed_below_the_median_and_the_plate_stays():
    clean = block_with_plate()
    noisy = segmentation_noise(clean, 0.8)
    out, noise = volume_fine_pass.fine_pass(noisy)
    assert noise.found and 2.0 < noise.height < 3.5
    median = ndimage.median_filter(noisy.astype(np.uint8), size=3).astype(bool)
    gaussian = ndimage.gaussian_filter(noisy.astype(np.float32), 1.5) > 0.5
    assert error(out, clean) < 0.7 * error(noisy, clean)
    assert error(out, clean) < error(median, clean)
    thin = metrics.thin_parts(clean, radius=2)  # the plate and the edges
    assert metrics.thin_parts_kept(out, thin) >= metrics.thin_parts_kept(gaussian, thin)
    plate = np.zeros_like(clean)
    plate[36:54, 20:44, 30:33] = True
    # The plate keeps what the noisy input had of it (84 %), where the Gaussian keeps 73 %.
    assert np.count_nonzero(out & plate) >= np.count_nonzero(noisy & plate)
    assert np.count_nonzero(gaussian & plate) < 0.9 * np.count_nonzero(noisy & plate)
    assert ndimage.label(out, structure=np.ones((3, 3, 3)))[1] == 1  # islands gone


def test_the_pipeline_runs_the_fine_pass_on_volumes_unless_off():
    clean = block_with_plate()
    noisy = segmentation_noise(clean, 0.8)
    on = pipeline.denoise_volume(noisy)
    assert on.fine_noise.found and error(on.mask, clean) < 0.7 * error(noisy, clean)
    off = pipeline.denoise_volume(noisy, fine_pass="off")
    assert off.fine_noise is None and error(off.mask, clean) > error(on.mask, clean)
    assert pipeline.denoise_volume(noisy, preset="thesis").fine_noise is None


def test_a_clean_volume_with_specks_and_spikes_of_its_own_passes_through():
    mask = block_with_plate()
    mask[2, 2, 2] = True  # a speck, far from the shape
    mask[54:60, 31, 31] = True  # a needle on the plate's top
    result = pipeline.denoise_volume(mask)
    assert result.voxels_changed == 0


def test_fine_pass_takes_on_off_preset_and_the_earlier_booleans():
    assert DenoiseParams().fine_pass == "auto"
    assert DenoiseParams(preset="thesis").fine_pass == "off"
    assert DenoiseParams(fine_pass=False).fine_pass == "off"
    assert DenoiseParams(preset="thesis", fine_pass=True).fine_pass == "on"
    with pytest.raises(ParameterError, match="fine_pass must be one of"):
        DenoiseParams(fine_pass="sometimes")
