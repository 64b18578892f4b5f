"""Which skeleton ball owns each voxel (`ball_owners.ray_owners`), a per-ball decision carried out on the
voxels (`owned_output`) and its seams smoothed (`seam_smoothed`)."""

import numpy as np
from conftest import cube_with_a_bump_and_a_dent
from scipy import ndimage

from skelfilter.core import ball_owners
from skelfilter.evaluation import metrics


def test_each_voxel_is_owned_by_the_ball_tangent_at_its_nearest_boundary_point():
    _, noisy = cube_with_a_bump_and_a_dent()
    voxels, owner, centres, radii = ball_owners.ray_owners(noisy)
    assert np.array_equal(voxels, np.flatnonzero(noisy))
    assert (owner >= 0).mean() > 0.99  # nearly every voxel has its ball
    # a voxel in the middle of the bump belongs to a ball centred in the bump
    middle = np.ravel_multi_index((15, 15, 33), noisy.shape)
    ball = centres[owner[np.searchsorted(voxels, middle)]]
    assert np.unravel_index(ball, noisy.shape)[2] >= 32
    # the owner's ball holds its voxel (to within a voxel: the walk ends within one of the centre)
    coords = np.stack(np.unravel_index(voxels[owner >= 0], noisy.shape), axis=1)
    centre = np.stack(np.unravel_index(centres[owner[owner >= 0]], noisy.shape), axis=1)
    assert (np.linalg.norm(coords - centre, axis=1) <= radii[owner[owner >= 0]] + 1.5).all()


def test_the_reach_keeps_the_voxels_near_the_boundary_with_the_same_owners():
    _, noisy = cube_with_a_bump_and_a_dent()
    all_voxels, all_owners, _, _ = ball_owners.ray_owners(noisy)
    voxels, owners, _, _ = ball_owners.ray_owners(noisy, reach=3)
    distance = ndimage.distance_transform_edt(noisy).reshape(-1)
    assert np.array_equal(voxels, np.flatnonzero(noisy.reshape(-1) & (distance <= 3)))
    assert np.array_equal(owners, all_owners[np.searchsorted(all_voxels, voxels)])


def test_dropped_balls_take_their_voxels_along_on_either_side():
    clean, noisy = cube_with_a_bump_and_a_dent()
    fg, bg = ball_owners.ray_owners(noisy), ball_owners.ray_owners(ball_owners.bounded_background(noisy))
    clean_fg = ndimage.distance_transform_edt(clean).reshape(-1)
    clean_bg = ndimage.distance_transform_edt(ball_owners.bounded_background(clean)).reshape(-1)
    out = ball_owners.owned_output(noisy, fg, bg, clean_fg[fg[2]] <= 0, clean_bg[bg[2]] <= 0)
    assert not out[15:17, 15:17, 33:35].any() and out[23:25, 23:25, 29:32].all()
    nothing = ball_owners.owned_output(noisy, fg, bg, np.zeros(len(fg[2]), bool), np.zeros(len(bg[2]), bool))
    assert np.array_equal(nothing, noisy)


def test_the_seam_smoothing_takes_the_thread_a_decision_left_of_a_handle_and_nothing_else():
    box = np.zeros((40, 40, 40), bool)
    box[8:32, 8:32, 8:32] = True
    notched = box.copy()
    notched[30:32, 30:32, 8:10] = False  # a notch at a corner, far from the noise
    noisy = notched.copy()
    noisy[13:27, 19:22, 32:38] = True  # a bump with a hole under it: a handle
    noisy[16:24, 19:22, 32:35] = False
    out = notched.copy()
    out[13:27, 20, 36] = out[13, 20, 32:37] = out[26, 20, 32:37] = True  # the decision left a thread of it
    smoothed = ball_owners.seam_smoothed(noisy, out)
    assert metrics.voxel_genus(noisy)["genus"] == metrics.voxel_genus(out)["genus"] == 1
    assert np.array_equal(smoothed, notched)  # the thread gone, the faces under it as they were
    assert np.array_equal(ball_owners.seam_smoothed(noisy, noisy), noisy)  # nothing changed: nothing moves
