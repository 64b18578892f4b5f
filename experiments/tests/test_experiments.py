"""Smoke tests of the experiments (``experiments/``): each against brute force or on a small case.
Run apart from the product's tests: ``python -m pytest experiments/tests``."""

import argparse

import numpy as np
import pytest
from scipy import ndimage

from experiments import (
    ball_oracle,
    chamfer_sides,
    dent_indicator,
    learned_ball_decision,
    noise_coverage,
    noise_handles,
    volume_second_run,
)


def test_auc_against_counting_pairs():
    rng = np.random.default_rng(0)
    values, positive = rng.normal(size=60), rng.random(60) < 0.4
    values[positive] += 0.8
    pairs = [(p > n) + 0.5 * (p == n) for p in values[positive] for n in values[~positive]]
    assert ball_oracle.auc(values, positive) == pytest.approx(np.mean(pairs))
    assert ball_oracle.auc(-values, positive) == pytest.approx(np.mean(pairs))  # turned around


def test_protrusion_beyond_larger_balls_is_the_height_a_ball_stands_out():
    shape = (48, 48, 48)
    flat = lambda *ijk: np.ravel_multi_index(ijk, shape)  # noqa: E731
    centres = np.array([flat(24, 24, 24), flat(24, 24, 37), flat(24, 24, 30)])
    radii = np.array([12.0, 2.0, 2.0])  # a big ball, a small one standing on it, one inside it
    out = ball_oracle.protrusion_beyond_larger(shape, centres, radii)
    # the big ball's union ends 12 voxels from its centre (to within a voxel on the grid)
    assert abs(out[1] - (37 + 2 - 24 - 12)) <= 1.0
    assert out[2] < 0
    assert out[0] == 2 * radii[0]  # nothing larger: it stands out by its whole size


def test_the_skeleton_course_tells_a_ball_on_a_rod_from_a_ball_off_it():
    grid = (40, 40, 40)
    rod = [(x, 20, 20) for x in range(4, 36)]
    blob = [(20, 21, 20), (20, 22, 20), (20, 23, 20)]  # a branch off the rod's middle, as a blob's skeleton
    centres = np.ravel_multi_index(np.array(rod + blob).T, grid)
    order = np.argsort(centres)
    columns = [c[np.argsort(order)] for c in learned_ball_decision.course(centres[order], grid, rounds=(8, 16))]
    linearity, planarity, spread, off_line, off_plane = columns[5:]  # over 16 steps
    on_rod, middle, tip = len(rod) // 4, len(rod) // 2, len(rod) + 2  # away from the branch, at it, its tip
    assert linearity[on_rod] > 0.95 and off_line[on_rod] < 0.1
    assert off_line[tip] > 2.0 > 1.0 > off_line[middle]  # measured: 2.28 and 0.49
    assert spread[tip] < spread[on_rod] and (planarity >= 0).all() and (off_plane >= 0).all()
    # over 8 steps the tip's neighbourhood is mostly the branch itself: it lies on its own line
    assert columns[3][tip] < 0.5


def test_the_dent_indicator_against_counting_windows():
    rng = np.random.default_rng(3)
    mask = np.zeros((14, 14, 14), dtype=bool)
    mask[3:11, 3:11, 3:11] = rng.random((8, 8, 8)) < 0.6
    w, h = 3, 1
    deep = high = 0
    for x, y, z in np.ndindex(mask.shape):
        mean = mask[max(x - h, 0):x + h + 1, max(y - h, 0):y + h + 1, max(z - h, 0):z + h + 1].sum() / w ** 3
        deep += (not mask[x, y, z]) and mean >= dent_indicator.DEEP
        high += bool(mask[x, y, z]) and mean < 1 - dent_indicator.DEEP
    assert deep and high
    assert dent_indicator.indicator(mask, w) == pytest.approx(deep / high, rel=1e-6)


def test_the_learned_decisions_clean_kind_is_the_shape_without_noise():
    assert learned_ball_decision._case("cube:clean") == ("cube", "clean")
    with pytest.raises(argparse.ArgumentTypeError, match="SHAPE:KIND"):
        learned_ball_decision._case("cube:spotless")
    _, noise = learned_ball_decision._noise("cube", "clean")
    assert noise.clean.any() and np.array_equal(noise.noisy, noise.clean)
    assert not noise.bumps.any() and not noise.dents.any()
    _, noisy = learned_ball_decision._noise("cube", "stripes")
    assert np.array_equal(noisy.clean, noise.clean) and noisy.bumps.any()


def test_the_noise_coverage_finds_noise_on_a_noisy_cube_and_none_on_the_clean_one(capsys, monkeypatch):
    monkeypatch.setattr(noise_coverage, "CLEAN_GRIDS", ((128, 6),))
    noise_coverage.main(["--groups", "clean", "--shapes", "cube"])
    assert "== clean, tuning: found on 0 of 1" in capsys.readouterr().out
    noisy = noise_coverage.quality.Case("cube", "stripes", 1).noise(96)
    mask = noise_coverage.mesh_pipeline.noisy_mesh(noise_coverage.shapes.load("cube"), noisy)[1].noisy
    estimate = noise_coverage.estimate(mask)
    assert estimate.found  # coverage 0.076 at 96 voxels


def test_volume_second_run_reads_both_estimates_and_scores_where_they_disagree():
    row = volume_second_run.run_case("bunny", "strong", 40)
    assert row["shape"] == "bunny" and row["input"] is not None and set(row["input"]) == {"found", "height", "coverage"}
    if row["smoothed"] is not None and row["input"]["found"] and not row["smoothed"]["found"]:
        assert row["default"] > 0 and row["input_only"] > 0


def test_the_dent_reading_fills_a_pit_and_nothing_on_a_clean_cube():
    from experiments import dent_closing

    cube = np.zeros((40, 40, 40), dtype=bool)
    cube[8:32, 8:32, 8:32] = True
    assert dent_closing.dent_reading(cube, 3.0, 40)["filled"] == 0.0
    cube[19:21, 19:21, 28:32] = False  # a pit 2 wide, 4 deep in the top face
    reading = dent_closing.dent_reading(cube, 3.0, 40)
    assert reading["filled"] > 0 and reading["depth"] > 0


def test_the_majority_proxy_takes_a_bump_and_a_dent_and_the_chamfer_is_zero_on_itself():
    from experiments import majority_reading
    clean = np.zeros((48, 48, 48), bool)
    clean[8:40, 8:40, 8:40] = True
    noisy = clean.copy()
    noisy[18:21, 18:21, 40:43] = True  # a bump
    noisy[28:31, 28:31, 37:40] = False  # a dent
    decided, reading = majority_reading.proxy(noisy, 9)
    assert not decided[18:21, 18:21, 41:43].any() and decided[28:31, 28:31, 37:39].all()
    assert majority_reading.surface_chamfer(clean, clean) == 0
    assert majority_reading.surface_chamfer(noisy, clean) > 0


def test_the_never_worse_guard_keeps_what_agrees_with_its_reference_and_gives_back_the_rest():
    from experiments import never_worse
    clean = np.zeros((40, 40, 40), bool)
    clean[8:32, 8:32, 8:32] = True
    noisy = clean.copy()
    noisy[14:17, 14:17, 32:35] = True  # a bump
    out = clean.copy()
    out[22:28, 22:28, 29:32] = False  # a halo the default dug where the input was right
    labels = never_worse.pieces(out ^ noisy, 0)
    guarded, keep, size = never_worse.guarded(noisy, out, labels, clean)
    assert not guarded[14:17, 14:17, 32:35].any() and guarded[22:28, 22:28, 29:32].all()
    assert size.sum() == np.count_nonzero(out ^ noisy) and keep.sum() == 2  # the unchanged voxels and the bump
    assert never_worse.pieces(out ^ noisy, 4).max() > labels.max()  # cut by the cubes


def test_closings_tunnels_only_fill_the_tunnel_not_the_pit():
    block = np.zeros((20, 20, 20), dtype=bool)
    block[3:17, 3:17, 3:17] = True
    block[8, 8, 3:17] = False  # a tunnel a voxel wide
    block[12, 12, 16] = False  # a pit
    rows = dict(noise_handles.closings(block))
    assert noise_handles.genus(block) == 1
    assert noise_handles.genus(rows["closing, cross, tunnels only"]) == 0
    assert rows["closing, cube"][12, 12, 16]  # the plain closing fills the pit, the tunnels only one does not
    assert not rows["closing, cube, tunnels only"][12, 12, 16] and noise_handles.genus(block) == 1


def test_cut_takes_an_arch_off_a_block():
    block = np.zeros((30, 30, 30), dtype=bool)
    block[5:25, 5:25, 5:15] = True
    block[10, 10, 15:18] = block[10, 19, 15:18] = True  # two posts
    block[10, 10:20, 17] = True  # a bridge between them: an arch, genus 1
    assert noise_handles.genus(block) == 1
    cut = noise_handles.cut(block)
    assert noise_handles.genus(cut) == 0 and not (cut & ~block).any()
    assert (cut[5:25, 5:25, 5:15] == block[5:25, 5:25, 5:15]).all()  # the block itself stays


def test_the_dent_rim_guard_gives_back_what_lies_within_delta_of_a_narrow_hole():
    noisy = np.zeros((24, 24, 24), dtype=bool)
    noisy[4:20, 4:20, 4:14] = True
    noisy[11:13, 11:13, 11:14] = False  # a dent 2 voxels wide and 3 deep in the top face
    output = noisy.copy()
    output[8:16, 8:16, 11:14] = False  # the dent widened by a halo
    output[4:6, 4:6, 12:14] = False  # a corner taken far from it
    holes = chamfer_sides.ball_closing(noisy, chamfer_sides.HOLE_CLOSING) & ~noisy
    hole_points = np.argwhere(holes)
    assert holes[11:13, 11:13, 11:14].all()
    for delta in (1, 2):
        guarded = chamfer_sides.rim_guard(noisy, output, delta)
        expected = output.copy()
        for point in np.argwhere(noisy & ~output):
            expected[tuple(point)] = np.sqrt(((hole_points - point) ** 2).sum(axis=1)).min() <= delta
        assert np.array_equal(guarded, expected)
        assert (guarded & ~output).any() and not guarded[4:6, 4:6, 12:14].any()


def test_the_moved_readings_are_the_clean_shape_at_sigma_zero_and_its_erosion_moved_in_by_one():
    clean = np.zeros((32, 32, 32), dtype=bool)
    clean[4:28, 5:27, 6:26] = True
    noise = argparse.Namespace(clean=clean, noisy=clean)
    readings = dict(chamfer_sides.moved_readings(noise, seed=1))
    assert np.array_equal(readings["oracle, surface moved by σ 0"], clean)
    assert np.array_equal(readings["oracle, surface moved in by 1"], ndimage.binary_erosion(clean))
    assert np.array_equal(readings["oracle, surface moved in by 0.5"], clean)
    moved = readings["oracle, surface moved by σ 2"]
    assert (moved ^ clean).any() and moved[14:18, 14:18, 14:18].all()  # the surface moves, the core stays


def test_the_offsets_of_the_clean_shape_read_its_inner_layer():
    from experiments import modal_reading

    box = np.zeros((20, 20, 20), dtype=bool)
    box[4:16, 4:16, 4:16] = True
    assert np.array_equal(modal_reading.offsets(box, box), [-1.0] * len(modal_reading.PERCENTILES))
    assert modal_reading.offsets(ndimage.binary_dilation(box), box)[2] == 1.0  # one voxel out
