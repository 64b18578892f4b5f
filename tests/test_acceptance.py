"""End-to-end figures on real shapes (the core issue's acceptance runs; benchmarks/acceptance.py prints them).

Bounds are the measured figures less a small margin, so a regression fails; where the
issue's target is not reached yet the test says so and the README gives the numbers.
"""

import numpy as np
import pytest
import trimesh
from conftest import load
from scipy import ndimage

from skelfilter import add_noise, denoise_mesh, denoise_volume
from skelfilter.mesh.voxelize import voxelize, voxelize_on_grid

# The thesis preset these figures were measured with, before 'thesis' followed the text literally.
PRESET = "thesis-tuned"
REACH = 3 + 2.1 + 1  # h + r + 1: farther than this from any noise voxel is "away from the noise"


def scores(clean, noise, result):
    near = ndimage.distance_transform_edt(~(noise.bumps | noise.dents)) <= REACH
    out = {"lost_away": (clean & ~near & ~result).sum() / clean.sum()}
    if noise.bumps.any():
        out["bumps_removed"] = 1 - (result & noise.bumps).sum() / noise.bumps.sum()
    if noise.dents.any():
        out["dents_filled"] = (result & noise.dents).sum() / noise.dents.sum()
    return out


@pytest.fixture(scope="module")
def cube_160():
    return voxelize(trimesh.creation.box((1.0, 1.0, 1.0)), 160, 16)[0]


@pytest.fixture(scope="module")
def fandisk_160():
    return voxelize(load("fandisk.obj"), 160, 16)[0]


def test_stripes_on_the_cube(cube_160):
    noise = add_noise(cube_160, p=0.014, r=2.1, h=3, l=6, seed=1)
    s = scores(cube_160, noise, denoise_volume(noise.noisy, preset=PRESET).mask)
    # measured 0.793 removed, 0.0 lost; the target of 0.95 removed is not met
    assert s["bumps_removed"] >= 0.75
    assert s["lost_away"] <= 0.01


def test_stripes_on_fandisk(fandisk_160):
    noise = add_noise(fandisk_160, p=0.014, r=2.1, h=3, l=6, seed=1)
    s = scores(fandisk_160, noise, denoise_volume(noise.noisy, preset=PRESET).mask)
    # measured 0.518 removed, 0.0 lost; the target of 0.95 removed is not met
    assert s["bumps_removed"] >= 0.48
    assert s["lost_away"] <= 0.01


def test_isolated_bumps_and_dents_are_removed(cube_160):
    noise = add_noise(cube_160, p=0.002, r=2.1, h=3, l=1, seed=2, dents=True)
    s = scores(cube_160, noise, denoise_volume(noise.noisy, preset=PRESET).mask)
    assert s["bumps_removed"] >= 0.93
    assert s["dents_filled"] >= 0.85  # measured 0.868: stage 1 first widens some dents a little
    assert s["lost_away"] <= 0.001


def test_bunny_comes_out_closed_with_its_ears():
    bunny = load("stanford-bunny.obj")
    assert not bunny.is_watertight
    out = denoise_mesh(bunny, resolution=160, preset=PRESET)
    assert out.is_watertight
    assert len(out.split(only_watertight=False)) == 1
    clean, grid = voxelize(bunny, 160, 8)
    back = voxelize_on_grid(out, grid)
    ys = np.argwhere(clean)[:, 1]
    ears = clean.copy()
    ears[:, : int(ys.min() + 0.8 * (ys.max() - ys.min())), :] = False  # the top fifth of the height
    # measured 0.898: the ears' thin rims lose a voxel layer to minification
    assert (back & ears).sum() / ears.sum() >= 0.85


def test_rocker_arm_keeps_its_through_hole():
    rocker = load("rocker-arm.obj")
    assert rocker.euler_number == 0  # genus 1 in
    out = denoise_mesh(rocker, resolution=128, preset=PRESET)
    assert out.is_watertight and out.euler_number == 0  # genus 1 out
    assert len(out.split(only_watertight=False)) == 1
