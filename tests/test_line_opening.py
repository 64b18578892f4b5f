"""The opening by line segments: against scipy's openings by a segment on small grids, and its properties."""

import numpy as np
import pytest
from scipy import ndimage

from skelfilter.core.line_opening import DIRECTIONS, line_opening


def _segment(direction, length):
    """The structuring element: ``length`` voxels along ``direction``, centred (odd lengths)."""
    steps = np.arange(length) - (length - 1) // 2
    points = np.outer(steps, direction)
    points -= points.min(axis=0)
    element = np.zeros(points.max(axis=0) + 1, dtype=bool)
    element[tuple(points.T)] = True
    return element


def _brute(volume, length):
    out = np.zeros_like(volume)
    for d in DIRECTIONS:
        out |= ndimage.binary_opening(volume, structure=_segment(d, length))
    return out


@pytest.mark.parametrize("seed, density, length", [(0, 0.6, 3), (1, 0.75, 5), (2, 0.85, 7), (3, 0.9, 1)])
def test_matches_scipy_openings_by_segments(seed, density, length):
    volume = np.random.default_rng(seed).random((13, 11, 9)) < density
    assert (line_opening(volume, length) == _brute(volume, length)).all()


def test_one_direction_at_a_time_and_the_grid_edge_ends_a_run():
    volume = np.zeros((6, 6, 6), dtype=bool)
    volume[0:6, 2, 2] = True  # six voxels along x, from edge to edge
    volume[0:4, 4, 4] = True
    assert line_opening(volume, 6, directions=[(1, 0, 0)]).sum() == 6
    assert not line_opening(volume, 6, directions=[(0, 1, 0)]).any()
    assert not line_opening(volume, 7).any()


def test_a_rod_keeps_its_length_and_loses_a_collar_and_blobs():
    rod = np.zeros((40, 40, 60), dtype=bool)
    rod[18:22, 18:22, 5:55] = True  # a leg 4 voxels wide, 50 long
    noisy = rod.copy()
    noisy[22:27, 17:22, 20:26] = True  # a blob 5 voxels out of one side
    noisy[14:26, 14:26, 40:43] = True  # a collar around it
    opened = line_opening(noisy, 15)
    assert (opened >= rod).all()
    assert not (opened & noisy & ~rod).any()


def test_refuses_what_is_not_a_length_or_a_step():
    volume = np.ones((3, 3, 3), dtype=bool)
    with pytest.raises(ValueError, match="length"):
        line_opening(volume, 0)
    with pytest.raises(ValueError, match="directions"):
        line_opening(volume, 2, directions=[(2, 0, 0)])
