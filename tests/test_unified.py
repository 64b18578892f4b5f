"""The unified skeleton model (thesis §4.2.1, §7.1.2-7.1.3): against a dense reference of the advection,
its properties on boxes and slabs, and selectable end to end."""

import numpy as np
import pytest
import trimesh
from scipy import ndimage as ndi

from skelfilter import add_noise, denoise_volume
from skelfilter.core import unified
from skelfilter.core.distance import gradient_at
from skelfilter.errors import ParameterError
from skelfilter.mesh.voxelize import voxelize
from skelfilter.params import DenoiseParams


def box(shape=(16, 17, 18), lo=(3, 3, 4), hi=(13, 14, 14)):
    volume = np.zeros(shape, bool)
    volume[lo[0]:hi[0], lo[1]:hi[1], lo[2]:hi[2]] = True
    return volume


def dense_density(volume, smoothing, steps, dt=unified.TIME_STEP):
    """Eq. 7.8 by the donor-cell scheme on the dense grid, one axis and sign at a time, with scipy's EDT."""
    shape = unified.smoothed_shape(volume, smoothing)
    distance = ndi.distance_transform_edt(shape)
    u = [np.zeros(shape.shape) for _ in range(3)]
    for k in range(3):
        ahead, behind = np.roll(distance, -1, k), np.roll(distance, 1, k)
        u[k] = np.where(shape, 0.5 * (ahead - behind), 0.0)
        # a component pointing out of the shape carries nothing (no mass leaves)
        u[k][(u[k] > 0) & ~np.roll(shape, -1, k)] = 0
        u[k][(u[k] < 0) & ~np.roll(shape, 1, k)] = 0
    mass = (shape & (distance == 1)).astype(float)
    peak = mass.copy()
    for _ in range(steps):
        moved = mass.copy()
        for k in range(3):
            plus, minus = dt * np.maximum(u[k], 0) * mass, dt * np.maximum(-u[k], 0) * mass
            moved += np.roll(plus, 1, k) + np.roll(minus, -1, k) - plus - minus
        np.testing.assert_allclose(moved.sum(), mass.sum())  # conservative (eq. 7.8)
        mass = moved
        peak = np.maximum(peak, mass)
    return peak


@pytest.mark.parametrize("smoothing", [0.0, 1.5])
def test_max_density_matches_the_dense_donor_cell_scheme(smoothing):
    rng = np.random.default_rng(3)
    volume = box() | (ndi.gaussian_filter(rng.random((16, 17, 18)), 1.5) > 0.53)
    volume[[0, 1, -2, -1]] = volume[:, [0, 1, -2, -1]] = volume[:, :, [0, 1, -2, -1]] = False
    got = unified.max_density(volume, smoothing, steps=25)
    np.testing.assert_allclose(got, dense_density(volume, smoothing, 25), rtol=1e-5, atol=1e-6)


def test_contraction_direction_is_unit_off_the_skeleton_and_grad_d_unsmoothed():
    volume = box()
    voxels = np.flatnonzero(volume)
    u = unified.contraction_direction(volume, 0.0, voxels)
    np.testing.assert_array_equal(u, gradient_at(ndi.distance_transform_edt(volume).astype(np.float32), voxels))
    # the middle of a face's layer: one nearest face, |u| = 1 towards the inside
    np.testing.assert_allclose(unified.contraction_direction(volume, 0.0, np.ravel_multi_index([[4], [8], [9]],
                                                                                                volume.shape)),
                               [[1.0, 0.0, 0.0]])
    assert not unified.contraction_direction(np.zeros_like(volume), 1.0, voxels).any()


def test_smoothing_removes_a_one_voxel_spike_and_zero_keeps_the_shape():
    volume = box()
    spiky = volume.copy()
    spiky[13, 8, 9] = True
    np.testing.assert_array_equal(unified.smoothed_shape(spiky, 0.0), spiky)
    assert not unified.smoothed_shape(spiky, 1.0)[13, 8, 9]
    assert unified.smoothed_shape(spiky, 1.0)[8, 8, 9]


def test_mass_collects_on_the_skeleton_of_a_slab():
    slab = box((30, 30, 19), (4, 4, 4), (26, 26, 15))  # 11 voxels thick: the mid-plane z = 9 is its skeleton
    density = unified.max_density(slab)
    middle = density[10:20, 10:20, 9]  # away from the rim, where the skeleton branches to the edges
    front = density[10:20, 10:20, 4:9]
    assert middle.min() > 1.0  # the two fronts' mass, more than one boundary voxel's
    assert front.max() <= 1.0  # a single front carries at most the mass it started with
    skel = np.zeros(slab.size, bool)
    skel[unified.usm_skeleton(slab)] = True
    skel = skel.reshape(slab.shape)
    assert skel[10:20, 10:20, 9].all() and not skel[10:20, 10:20, 4:9].any()


def test_usm_parameters_apply_only_where_they_take_effect():
    assert DenoiseParams(skeleton="usm", usm_min_density=2.0).usm_min_density == 2.0
    assert DenoiseParams(velocity="unified", usm_smoothing=0.0).usm_smoothing == 0.0
    with pytest.raises(ParameterError, match="usm_smoothing takes effect only with skeleton usm or velocity unified"):
        DenoiseParams(usm_smoothing=2.0)
    with pytest.raises(ParameterError, match="usm_min_density takes effect only with skeleton usm"):
        DenoiseParams(velocity="unified", usm_min_density=2.0)
    with pytest.raises(ParameterError, match="saliency_threshold takes effect only with pruning saliency"):
        DenoiseParams(saliency_threshold=3.0)
    with pytest.raises(ParameterError, match="usm_smoothing must be a number in"):
        DenoiseParams(skeleton="usm", usm_smoothing=-1.0)


@pytest.mark.parametrize("variant", [{"skeleton": "usm"}, {"velocity": "unified"},
                                     {"skeleton": "usm", "velocity": "unified", "usm_smoothing": 0.0}])
def test_usm_variants_remove_bumps_and_keep_the_core(variant):
    cube = voxelize(trimesh.creation.box((1.0, 1.0, 1.0)), 40, 12)[0]
    noise = add_noise(cube, p=0.014, r=2.1, h=3, l=1, seed=1)
    mask = denoise_volume(noise.noisy, preset="thesis", stages="foreground", edt_filter="none", **variant).mask
    assert (mask & noise.bumps).sum() <= 0.5 * noise.bumps.sum()
    core = ndi.binary_erosion(cube, iterations=6)
    assert (mask & core).sum() == core.sum()
