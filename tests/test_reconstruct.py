"""Reverse EDT (thesis §7.4) against brute-force unions of balls."""

import numpy as np
import pytest
from scipy import ndimage as ndi

from skelfilter.core.reconstruct import (
    naive_union_of_balls,
    reconstruction,
    reverse_edt,
    signed_distance,
    union_of_balls,
)
from skelfilter.errors import ParameterError


def _brute(shape, centres, radii):
    """Squared distances of every voxel to every centre, ``(n_voxels, n_centres)``."""
    x = np.stack(np.unravel_index(np.arange(np.prod(shape)), shape), axis=1)
    c = np.stack(np.unravel_index(centres, shape), axis=1)
    return ((x[:, None, :] - c[None, :, :]) ** 2).sum(axis=-1)


def _blob(shape, seed, sigma=2.5, level=0.02):
    noise = np.random.default_rng(seed).standard_normal(shape)
    return ndi.gaussian_filter(noise, sigma) > level


CASES = [((20, 20, 20), 0, 30), ((24, 28, 32), 1, 60), ((32, 32, 32), 2, 45), ((1, 17, 5), 3, 4)]


@pytest.mark.parametrize("shape, seed, n", CASES)
def test_power_and_owner_match_brute_force(shape, seed, n):
    rng = np.random.default_rng(seed)
    centres = rng.integers(0, np.prod(shape), n)
    centres[: n // 5] = centres[n // 5 : 2 * (n // 5)]  # several centres in one voxel
    radii = rng.uniform(0, 9, n)
    power, owner = reverse_edt(shape, centres, radii)
    assert power.dtype == np.float32 and owner.dtype == np.int32 and power.shape == shape
    d2 = _brute(shape, centres, radii)
    best = (radii**2 - d2).max(axis=1)
    np.testing.assert_allclose(power.ravel(), best, rtol=0, atol=1e-3)
    o = owner.ravel()
    assert o.min() >= 0 and o.max() < n
    np.testing.assert_allclose(radii[o] ** 2 - d2[np.arange(o.size), o], best, rtol=0, atol=1e-9)


def test_integer_squared_radii_are_exact():
    shape = (26, 21, 30)
    rng = np.random.default_rng(5)
    centres = rng.integers(0, np.prod(shape), 50)
    k = rng.integers(0, 60, 50)
    for radii in (np.sqrt(k), np.sqrt(k).astype(np.float32)):
        power, _ = reverse_edt(shape, centres, radii)
        best = (k - _brute(shape, centres, radii)).max(axis=1)
        np.testing.assert_array_equal(power.ravel(), best.astype(np.float32))


@pytest.mark.parametrize("seed", [0, 1])
def test_reconstruction_is_union_of_open_balls(seed):
    shape = (30, 25, 28)
    rng = np.random.default_rng(seed)
    centres = rng.integers(0, np.prod(shape), 40)
    # Half the radii sit exactly on voxel distances: the balls are open there.
    squared = np.where(rng.random(40) < 0.5, rng.integers(0, 50, 40), rng.uniform(0, 49, 40))
    radii = np.sqrt(squared)
    union = (_brute(shape, centres, radii) < squared).any(axis=1).reshape(shape)
    np.testing.assert_array_equal(reconstruction(reverse_edt(shape, centres, radii)[0]), union)
    np.testing.assert_array_equal(naive_union_of_balls(shape, centres, radii), union)  # Fig. 7.6's baseline
    np.testing.assert_array_equal(union_of_balls(shape, centres, radii)[0], union)


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_all_voxels_with_edt_radii_rebuild_the_shape(seed, dtype):
    shape = (32, 30, 28)
    x = _blob(shape, seed)
    x[0, :, :] |= x[1, :, :]  # touching the volume border is fine too
    distance = ndi.distance_transform_edt(x).astype(dtype)
    centres = np.flatnonzero(x)
    power, _ = reverse_edt(shape, centres, distance.ravel()[centres])
    np.testing.assert_array_equal(reconstruction(power), x)


def test_cube_rebuilt_from_its_edt():
    x = np.zeros((24, 24, 24), bool)
    x[3:21, 4:20, 5:19] = True
    distance = ndi.distance_transform_edt(x)
    centres = np.flatnonzero(x)
    np.testing.assert_array_equal(reconstruction(reverse_edt(x.shape, centres, distance.ravel()[centres])[0]), x)


def test_largest_ball_wins_in_a_shared_voxel():
    shape = (9, 9, 9)
    centres = np.array([364, 364, 364])  # voxel (4, 4, 4)
    power, owner = reverse_edt(shape, centres, np.array([1.0, 3.0, 2.0]))
    assert np.all(owner == 1)
    assert power[4, 4, 4] == 9.0 and power[4, 4, 7] == 0.0


def test_zero_radius_adds_nothing():
    power, owner = reverse_edt((5, 5, 5), [62], [0.0])
    assert power[2, 2, 2] == 0 and not reconstruction(power).any()


def test_empty_centres():
    shape = (4, 5, 6)
    power, owner = reverse_edt(shape, np.array([], np.int64), np.array([]))
    assert np.all(power == -np.inf) and np.all(owner == -1)
    assert not reconstruction(power).any()
    phi = signed_distance(shape, np.array([], np.int64), np.array([]), owner)
    assert phi.dtype == np.float32 and np.all(phi == -np.inf)


def test_signed_distance_of_one_ball_is_exact():
    shape = (21, 23, 25)
    centre = np.ravel_multi_index((10, 9, 13), shape)
    for r in (4.3, np.sqrt(20.0)):
        power, owner = reverse_edt(shape, [centre], [r])
        phi = signed_distance(shape, [centre], [r], owner)
        true = r - np.sqrt(_brute(shape, [centre], [r])[:, 0])
        np.testing.assert_allclose(phi.ravel(), true, rtol=0, atol=1e-5)
        np.testing.assert_array_equal(np.sign(phi), np.sign(power))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_signed_distance_sign_and_bound(seed):
    shape = (28, 24, 30)
    rng = np.random.default_rng(seed)
    centres = rng.integers(0, np.prod(shape), 40)
    radii = np.where(rng.random(40) < 0.5, np.sqrt(rng.integers(1, 40, 40)), rng.uniform(0.5, 8, 40))
    power, owner = reverse_edt(shape, centres, radii)
    phi = signed_distance(shape, centres, radii, owner)
    assert phi.dtype == np.float32
    np.testing.assert_array_equal(np.sign(phi), np.sign(power))
    assert np.any(phi == 0)  # sqrt-integer radii put voxels exactly on the boundary
    # Phi is one term of eq. 7.26, so at most its maximum (the distance to the union outside it).
    redt = (radii - np.sqrt(_brute(shape, centres, radii))).max(axis=1)
    assert np.all(phi.ravel() <= redt + 1e-5)


def test_invalid_input():
    with pytest.raises(ParameterError):
        reverse_edt((4, 4, 4), [0, 1], [1.0])
    with pytest.raises(ParameterError):
        reverse_edt((4, 4, 4), [64], [1.0])
    with pytest.raises(ParameterError):
        reverse_edt((4, 4, 4), [3], [-1.0])
    with pytest.raises(ParameterError):
        reverse_edt((4, 4, 4), [3], [np.nan])
    with pytest.raises(ParameterError):
        signed_distance((4, 4, 4), [3], [1.0], np.full((4, 4, 5), 0, np.int32))
    with pytest.raises(ParameterError):
        signed_distance((4, 4, 4), [3], [1.0], np.full((4, 4, 4), 1, np.int32))
