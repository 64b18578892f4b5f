"""Noise estimate and feature restoration: against brute force on small grids, and the properties."""

import numpy as np
import pytest
from scipy import ndimage

from skelfilter.core.decision import feature_restore, noise_estimate
from skelfilter.core.line_opening import line_opening


def _brute_height(part, base):
    """Distance from each voxel of ``part`` to the nearest voxel of ``base``, by listing all pairs."""
    p, b = np.argwhere(part), np.argwhere(base)
    d = np.sqrt(((p[:, None, :] - b[None, :, :]) ** 2).sum(axis=2)).min(axis=1)
    out = np.zeros(part.shape, dtype=np.float64)
    out[tuple(p.T)] = d
    return out


def _block(shape=(40, 40, 40), lo=8, hi=32):
    v = np.zeros(shape, dtype=bool)
    v[lo:hi, lo:hi, lo:hi] = True
    return v


def _bumps(body, count, height, seed=0, radius=1):
    """``body`` with ``count`` square columns ``2 radius + 1`` wide and ``height`` high on its top face."""
    rng = np.random.default_rng(seed)
    top = np.flatnonzero(body.any(axis=(0, 1)))[-1]
    xs = np.flatnonzero(body.any(axis=(1, 2)))
    ys = np.flatnonzero(body.any(axis=(0, 2)))
    out = body.copy()
    for _ in range(count):
        x = rng.integers(xs[0] + radius, xs[-1] - radius + 1)
        y = rng.integers(ys[0] + radius, ys[-1] - radius + 1)
        out[x - radius:x + radius + 1, y - radius:y + radius + 1, top + 1:top + 1 + height] = True
    return out


def test_height_above_matches_brute_force():
    rng = np.random.default_rng(3)
    base = np.zeros((14, 15, 16), dtype=bool)
    base[3:8, 4:9, 5:10] = True
    part = (rng.random(base.shape) < 0.2) & ~base
    box, height = noise_estimate.height_above(part, base, reach=20.0)
    full = np.zeros(base.shape, dtype=np.float32)
    full[box] = height
    np.testing.assert_allclose(full, _brute_height(part, base), atol=1e-5)


def _brute_dynamics(height):
    """{top voxel: dynamic} of every regional maximum of ``height`` (distinct values > 0): the drop
    from its top to the highest level at which its 26-connected level set holds a higher voxel."""
    cube = np.ones((3, 3, 3), dtype=bool)
    levels = np.unique(height[height > 0])[::-1]
    tops = (ndimage.maximum_filter(height, footprint=cube, mode="constant") == height) & (height > 0)
    dynamics = {}
    for top in map(tuple, np.argwhere(tops)):
        peak = height[top]
        dynamics[top] = peak  # no higher voxel joins it above the floor
        for level in levels[levels <= peak]:
            labels = ndimage.label(height >= level, structure=cube)[0]
            if height[labels == labels[top]].max() > peak:
                dynamics[top] = peak - level
                break
    return dynamics


def test_prominent_peaks_and_surface_cells_match_brute_force():
    rng = np.random.default_rng(5)
    for shape in ((8, 9, 10), (1, 6, 6), (12, 3, 9)):
        for _ in range(6):
            height = ndimage.gaussian_filter(rng.random(shape), 1.0)
            height = np.maximum((height - np.quantile(height, 0.3)) * 40, 0).astype(np.float32)
            for least in (0.2, 0.6, 1.5):
                tops, heights = noise_estimate.prominent_peaks(height, least)
                expected = {top for top, dynamic in _brute_dynamics(height).items() if dynamic >= least}
                assert set(map(tuple, tops)) == expected
                np.testing.assert_array_equal(heights, height[tuple(tops.T)])
        volume = rng.random(shape) < 0.8  # set voxels on the array's faces too
        for cell in (1, 2, 3):
            surface = np.argwhere(volume & ~ndimage.binary_erosion(volume)) // cell
            assert noise_estimate.surface_cells(volume, cell) == len(np.unique(surface, axis=0))


def test_a_plateau_and_a_wiggling_ridge_are_one_peak():
    height = np.zeros((3, 3, 20), dtype=np.float32)
    height[1, 1, 2:18] = 4.0
    height[1, 1, 2:18:3] = 4.5  # wiggles of half a voxel along the ridge
    height[1, 1, 17] = 6.0
    tops, heights = noise_estimate.prominent_peaks(height, 1.0)
    assert [tuple(t) for t in tops] == [(1, 1, 17)] and heights.tolist() == [6.0]
    height[1, 1, 10] = 1.0  # a saddle 3.5 below the lower top: two peaks
    tops, heights = noise_estimate.prominent_peaks(height, 1.0)
    assert sorted(heights.tolist()) == [4.5, 6.0]


def test_height_above_is_capped_far_from_the_base():
    base = np.zeros((30, 10, 10), dtype=bool)
    base[1:3, 4:6, 4:6] = True
    part = np.zeros_like(base)
    part[20:28, 4:6, 4:6] = True
    box, height = noise_estimate.height_above(part, base, reach=3.0)
    assert (height[part[box]] >= 3.0).all()


def test_clean_block_passes_as_noise_free():
    block = _block()
    assert not noise_estimate.estimate_noise(block, block, 24).found


def test_many_low_bumps_are_found_with_their_height():
    body = _block((80, 80, 50), 10, 70)
    body[:, :, 30:] = False
    noisy = body.copy()
    for x in range(13, 68, 5):  # 121 columns 3 x 3 wide, 2 voxels apart: each is a peak of its own
        for y in range(13, 68, 5):
            noisy[x - 1:x + 2, y - 1:y + 2, 30:34] = True
    estimate = noise_estimate.estimate_noise(noisy, body, 60)
    assert estimate.found and estimate.peaks == 121
    assert 3.5 <= estimate.height <= 4.5  # the columns stand 4 voxels above the body
    assert "4." in estimate.describe()


def test_a_few_tall_features_are_not_noise():
    body = _block((80, 80, 70), 10, 70)
    body[:, :, 30:] = False
    legs = body.copy()
    for x, y in ((20, 20), (20, 60), (60, 20), (60, 60)):
        legs[x - 1:x + 2, y - 1:y + 2, 30:60] = True  # 30 voxels tall: above HIGHEST_NOISE
    assert not noise_estimate.estimate_noise(legs, body, 60).found


def test_slats_along_the_surface_are_not_noise():
    # Long bars standing 4 voxels on the top face (a chair's slats pruned along their length): their
    # ridges cross many cells (0.11 of them counted voxel by voxel), but each is one peak.
    body = _block((80, 80, 50), 10, 70)
    body[:, :, 30:] = False
    slats = body.copy()
    for x in range(14, 70, 8):
        slats[x:x + 2, 12:68, 30:34] = True
    estimate = noise_estimate.estimate_noise(slats, body, 60)
    assert not estimate.found and estimate.coverage < 0.02


def test_features_by_extent_gives_back_the_tall_parts_whole():
    body = _block((60, 60, 70), 10, 50)
    body[:, :, 30:] = False
    shape = _bumps(body, 30, 3, seed=2)
    shape[20:23, 20:23, 30:60] = True  # a leg 30 voxels tall
    restored = feature_restore.features_by_extent(shape, body, height=5.0)
    leg = np.zeros_like(shape)
    leg[20:23, 20:23, 30:60] = True
    assert (restored >= leg).all()
    # the bumps far from the leg stay removed
    bumps = shape & ~body & ~ndimage.binary_dilation(leg, iterations=8)
    assert bumps.any() and not (restored & bumps).any()


def test_connections_rejoin_what_the_pruning_cut_apart():
    shape = np.zeros((60, 30, 30), dtype=bool)
    shape[5:25, 5:25, 5:25] = True
    shape[35:55, 5:25, 5:25] = True
    shape[25:35, 13:17, 13:17] = True  # the neck
    pruned = shape.copy()
    pruned[25:35] = False
    pruned[24:36, 10:20, 10:20] = False
    bridge = feature_restore.connections(shape, pruned, width=2.0)
    joined = pruned | bridge
    assert ndimage.label(joined, structure=np.ones((3, 3, 3)))[1] == 1
    assert not (bridge & ~shape).any()


def test_connections_leave_one_piece_alone():
    shape = _block()
    pruned = shape.copy()
    pruned[8:12] = False
    assert not feature_restore.connections(shape, pruned, width=3.0).any()


def test_skin_far_from_noise():
    body = _block((50, 50, 50), 10, 40)
    shape = body.copy()
    shape[20:23, 20:23, 40:46] = True  # a tall removed column
    pruned = body.copy()
    pruned[10, :, :] = False  # a one-voxel skin far away, on the other side
    pruned[:, :, 39] = False  # a skin right under the column and around it
    skin = feature_restore.skin_far_from_noise(shape, pruned, reach=3.0)
    assert skin[10, 15:35, 15:35].all()
    assert not skin[20:23, 20:23, 39].any()
    assert not (skin & ~shape).any()


@pytest.mark.parametrize("height", [2.0, 5.0])
def test_features_by_extent_never_adds_outside_the_removed_set(height):
    rng = np.random.default_rng(5)
    shape = ndimage.binary_closing(rng.random((30, 30, 30)) < 0.55, iterations=2)
    pruned = ndimage.binary_erosion(shape, iterations=2)
    restored = feature_restore.features_by_extent(shape, pruned, height)
    assert not (restored & ~(shape & ~pruned)).any()


@pytest.mark.parametrize("radius", [1.0, 2.0, 3.0])
def test_ball_closing_matches_scipy_closing_by_a_ball(radius):
    volume = np.random.default_rng(int(radius)).random((14, 12, 10)) < 0.5
    r = int(radius)
    grid = np.indices((2 * r + 1,) * 3) - r
    ball = (grid ** 2).sum(axis=0) <= radius ** 2
    padded = np.pad(volume, r + 1)
    expected = ndimage.binary_closing(padded, structure=ball)[r + 1:-r - 1, r + 1:-r - 1, r + 1:-r - 1]
    assert (feature_restore.ball_closing(volume, radius) == expected).all()


@pytest.mark.parametrize("radius", [1.0, 2.0, 3.0])
def test_ball_opening_matches_scipy_opening_by_a_ball(radius):
    volume = ndimage.binary_closing(np.random.default_rng(int(radius)).random((18, 16, 14)) < 0.6)
    r = int(radius)
    grid = np.indices((2 * r + 1,) * 3) - r
    ball = (grid ** 2).sum(axis=0) <= radius ** 2
    padded = np.pad(volume, r + 1)
    expected = ndimage.binary_opening(padded, structure=ball)[r + 1:-r - 1, r + 1:-r - 1, r + 1:-r - 1]
    assert expected.any() and (feature_restore.ball_opening(volume, radius) == expected).all()
    assert not feature_restore.ball_opening(np.zeros((5, 5, 5), bool), radius).any()


def test_along_lines_keeps_a_dented_leg_and_drops_the_blobs_on_it():
    body = _block((40, 40, 80), 5, 35)
    body[:, :, 35:] = False
    leg = np.zeros_like(body)
    leg[17:23, 17:23, 35:75] = True  # 6 voxels wide, 40 long
    noisy = body | leg
    noisy[23:27, 18:22, 50:54] = True  # a blob 4 voxels out of one side: 10 across with the leg
    noisy[17:20, 17:23, 60:63] = False  # a dent 3 deep across it
    noisy[17:20, 20:23, 45:48] = False
    restored = feature_restore.features_by_extent(noisy, body, 6.0)
    kept = feature_restore.along_lines(noisy, restored, 6.0)
    assert (kept >= (leg & noisy)).all()
    assert not kept[23:27, 18:22, 50:54].any()  # runs of 11 voxels (1.75 x 6) find none through it
    assert not (kept & ~restored).any()


def test_along_lines_on_its_crop_equals_the_whole_grid():
    rng = np.random.default_rng(3)
    shape = ndimage.binary_closing(rng.random((70, 40, 40)) < 0.6, iterations=2)
    restored = shape.copy()
    restored[:30] = False
    restored[:, :10] = False
    height = 4.0
    length = int(np.ceil(feature_restore.RUN_PER_HEIGHT * height))
    whole = restored & line_opening(feature_restore.ball_closing(shape, feature_restore.DENT_FILL), length)
    assert whole.any() and (feature_restore.along_lines(shape, restored, height) == whole).all()
