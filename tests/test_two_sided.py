"""The two-sided decision (`skelfilter.core.decision.two_sided`): dents read from the foreground's result,
both sides decided by the input's modal reading on the majority reading's thick parts, and ``stages``
auto in the pipeline."""

import numpy as np
import pytest
from scipy import ndimage

from skelfilter import denoise_volume
from skelfilter.core.decision import two_sided
from skelfilter.core.decision.feature_restore import ball_opening
from skelfilter.core.synthetic_noise import add_noise


def _box(n=48, a=8):
    box = np.zeros((n, n, n), bool)
    box[a:n - a, a:n - a, a:n - a] = True
    return box


def test_the_majority_reading_is_the_sign_of_the_median_signed_distance():
    rng = np.random.default_rng(3)
    blob = ndimage.gaussian_filter(rng.random((30, 30, 30)), 2.0) > 0.5
    blob[[0, -1], :, :] = blob[:, [0, -1], :] = blob[:, :, [0, -1]] = False
    signed = ndimage.distance_transform_edt(blob) - ndimage.distance_transform_edt(~blob)
    for window in (3, 5, 7):
        median = ndimage.median_filter(signed, size=window, mode="constant", cval=-1.0) > 0
        assert np.array_equal(two_sided.majority_reading(blob, window), median)


def test_thick_parts_are_where_half_the_window_fits():
    plate = np.zeros((60, 60, 30), bool)
    plate[5:55, 5:55, 10:18] = True  # 8 voxels thick: thinner than the window
    assert not two_sided.thick_parts(plate, 15).any()
    block = _box(60, 10)
    thick = two_sided.thick_parts(block, 15)
    assert thick[block].mean() > 0.95 and not thick[block.shape[0] // 2, block.shape[1] // 2, 1]


def test_the_modal_reading_ignores_a_bump_and_a_dent_and_rounds_the_edges_less_than_the_majority_reading():
    box = _box(64, 12)
    noisy = box.copy()
    noisy[24:27, 24:27, 52:55] = True  # a bump 3 voxels high on the top face
    noisy[36:39, 36:39, 49:52] = False  # a dent 3 deep
    reading = two_sided.modal_reading(noisy)
    for column in (np.s_[24:27, 24:27, 44:60], np.s_[36:39, 36:39, 44:60], np.s_[30:33, 30:33, 44:60]):
        assert np.array_equal(reading[column], box[column])  # the bump's, the dent's, the face between them
    assert (reading ^ box).sum() < (two_sided.majority_reading(noisy) ^ box).sum()
    assert not two_sided.modal_reading(np.zeros((20, 20, 20), bool)).any()


def test_both_sides_decided_on_the_thick_part_and_the_thin_part_kept_as_given():
    clean = _box(64, 12)
    clean[30:34, 30:34, 52:62] = True  # a rod 4 voxels thick standing on the top: a thin part
    noisy = clean.copy()
    noisy[20:23, 20:23, 52:55] = True  # a bump
    noisy[40:43, 40:43, 49:52] = False  # a dent
    kept = clean.copy()
    kept[40:43, 40:43, 49:52] = False  # the foreground's result: the bump gone, the dent kept
    out = two_sided.decide_both_sides(noisy, kept)
    assert not out[20:23, 20:23, 52:55].any() and out[40:43, 40:43, 49:52].all()
    assert np.array_equal(out[26:38, 26:38, 54:], kept[26:38, 26:38, 54:])  # the rod as the result has it
    # What it takes from the box is a sliver of its edges, which a ball of the bumps' size does not reach;
    # its faces stay.
    taken = kept & ~out
    assert not (taken & ball_opening(noisy, two_sided.BUMP_RADIUS)).any() and taken.sum() < 0.02 * clean.sum()
    faces = np.zeros_like(clean)
    faces[16:48, 16:48, :] = faces[16:48, :, 16:48] = faces[:, 16:48, 16:48] = True
    assert not ((out ^ clean) & faces & ~ndimage.binary_dilation(noisy ^ clean, iterations=4)).any()
    # no thick part: the result as it was
    assert np.array_equal(two_sided.decide_both_sides(noisy, kept, window=65), kept)


@pytest.fixture(scope="module")
def pitted_cube():
    clean = _box(110, 15)
    return clean, add_noise(clean, p=0.014, r=2.1, h=3, l=6, seed=1, dents=True)


def test_dents_are_read_on_a_pitted_surface_not_on_a_clean_one_or_a_real_concavity(pitted_cube):
    box = _box()
    assert not two_sided.read_dents(box).found and two_sided.read_dents(box).depth == 0
    grooved = box.copy()
    grooved[20:28, 8:40, 30:40] = False  # a channel 8 wide, 10 deep: a real concavity
    assert not two_sided.read_dents(grooved).found
    _, noise = pitted_cube
    reading = two_sided.read_dents(noise.noisy & ~noise.bumps)  # the bumps taken, the dents left
    assert reading.found and reading.depth >= two_sided.PITTED_DEPTH and "pitted" in reading.describe()


def test_the_default_takes_dents_where_the_foreground_alone_leaves_them(pitted_cube):
    clean, noise = pitted_cube
    noisy = noise.noisy.copy()
    one_sided = denoise_volume(noise.noisy, stages="foreground", fine_pass="off")
    default = denoise_volume(noise.noisy, fine_pass="off")
    assert np.array_equal(noise.noisy, noisy)  # the input is not touched
    assert one_sided.dents is None and default.dents.found and default.dents.changed > 0

    def left(result, side):
        return (side & (result.mask if side is noise.bumps else ~result.mask)).sum() / side.sum()

    assert left(one_sided, noise.dents) == 1.0 and left(default, noise.dents) < 0.45
    assert left(default, noise.bumps) < left(one_sided, noise.bumps)  # the bumps it kept taken too
    error = [(r.mask ^ clean).sum() / (noise.noisy ^ clean).sum() for r in (one_sided, default)]
    assert error[1] < 0.6 < error[0]
    # the field agrees with the mask it was made again for
    assert np.array_equal(default.field > 0, default.mask)


def test_bumps_alone_and_a_clean_shape_are_not_read_as_dented():
    clean = _box(110, 15)
    noise = add_noise(clean, p=0.014, r=2.1, h=3, l=6, seed=1)
    default = denoise_volume(noise.noisy, fine_pass="off")
    one_sided = denoise_volume(noise.noisy, stages="foreground", fine_pass="off")
    assert not default.dents.found and np.array_equal(default.mask, one_sided.mask)
    passed = denoise_volume(clean)
    assert not passed.dents.found and np.array_equal(passed.mask, clean)


def test_the_reading_of_nothing_left_is_no_dents_and_the_box_gives_the_grid_s_counts():
    assert not two_sided.read_dents(np.zeros((20, 20, 20), bool)).found
    box = _box()
    pitted = box.copy()
    pitted[20:22, 20:22, 37:40] = False
    grid = np.zeros((80, 70, 60), bool)
    grid[10:58, 5:53, 3:51] = pitted
    assert two_sided.read_dents(grid).depth == pytest.approx(two_sided.read_dents(pitted).depth)
