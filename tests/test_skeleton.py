"""Distance/feature transform and skeleton rules against brute force."""

import numpy as np
import pytest
from scipy import ndimage

from skelfilter.core.distance import distance_and_features, distance_transform, feature_points, gradient_at
from skelfilter.core.neighbourhood import OFFSETS_26, unravel
from skelfilter.core.skeleton import extended_feature_points, ie_skeleton, ima_skeleton


def blob(shape=(24, 22, 20), seed=0):
    rng = np.random.default_rng(seed)
    noise = ndimage.gaussian_filter(rng.random(shape), 2.0)
    v = noise > np.quantile(noise, 0.55)
    v[:2] = v[-2:] = False
    v[:, :2] = v[:, -2:] = False
    v[:, :, :2] = v[:, :, -2:] = False
    return v


@pytest.mark.parametrize("seed", [0, 1])
def test_distance_and_features_match_brute_force(seed):
    v = blob(seed=seed)
    d, f = distance_and_features(v)
    inside = np.argwhere(v)
    outside = np.argwhere(~v)
    d2 = ((inside[:, None, :] - outside[None, :, :]) ** 2).sum(-1)
    brute = np.sqrt(d2.min(axis=1))
    assert np.allclose(d[tuple(inside.T)], brute, atol=1e-5)
    fx = np.stack(np.unravel_index(f[tuple(inside.T)], v.shape), axis=1)
    # the feature point is a background voxel at exactly distance D ...
    assert not v[tuple(fx.T)].any()
    assert np.allclose(np.sqrt(((fx - inside) ** 2).sum(1)), brute, atol=1e-5)
    # ... that touches the set (it lies in the boundary layer M, eq. 7.12)
    m = ndimage.binary_dilation(v, np.ones((3, 3, 3), bool)) & ~v
    assert m[tuple(fx.T)].all()
    flat = np.ravel_multi_index(tuple(inside.T), v.shape)
    assert np.array_equal(feature_points(f, flat), np.ravel_multi_index(tuple(fx.T), v.shape))
    assert (d[~v] == 0).all()
    assert f.dtype == np.int32 and (f.reshape(-1)[~v.reshape(-1)] == np.flatnonzero(~v)).all()


@pytest.mark.parametrize("seed", range(6))
def test_features_are_scipys(seed):
    # The same feature points as scipy's transform, ties included (they reach the results).
    rng = np.random.default_rng(seed)
    shape = tuple(rng.integers(2, 40, 3))
    v = rng.random(shape) < rng.uniform(0.5, 0.99) if seed % 2 else blob(shape, seed)
    v.reshape(-1)[0] = False
    d, f = distance_and_features(v)
    sd, si = ndimage.distance_transform_edt(v, return_indices=True)
    assert np.array_equal(d, sd.astype(np.float32))
    assert np.array_equal(f, np.ravel_multi_index(tuple(si), shape))


@pytest.mark.parametrize("seed", range(6))
def test_distance_transform_is_scipys(seed):
    # The distances alone: the same float32 as the feature transform's and scipy's, lines without a
    # background voxel along the first axes included.
    rng = np.random.default_rng(seed)
    shape = tuple(rng.integers(1, 30, 3))
    v = rng.random(shape) < rng.uniform(0.5, 0.999) if seed % 2 else blob(shape, seed)
    v.reshape(-1)[-1] = False
    d = distance_transform(v)
    assert d.dtype == np.float32
    assert np.array_equal(d, distance_and_features(v)[0])
    assert np.array_equal(d, ndimage.distance_transform_edt(v).astype(np.float32))


def test_gradient_at_is_central_difference():
    d = np.random.default_rng(3).random((6, 7, 8)).astype(np.float32)
    g = gradient_at(d, np.array([np.ravel_multi_index((2, 3, 4), d.shape)]))
    central = [(d[3, 3, 4] - d[1, 3, 4]) / 2, (d[2, 4, 4] - d[2, 2, 4]) / 2, (d[2, 3, 5] - d[2, 3, 3]) / 2]
    assert np.allclose(g[0], central)


def test_ie_skeleton_brute_force_rule():
    v = blob(seed=2)
    d, _ = distance_and_features(v)
    s = ie_skeleton(d)
    gx, gy, gz = np.gradient(d.astype(np.float64))
    e = d * np.sqrt(np.maximum(0, 1 - (gx**2 + gy**2 + gz**2)))
    brute = np.flatnonzero(((e >= 1) & v).reshape(-1))
    assert np.array_equal(s, brute)


def test_ie_skeleton_of_slab_is_its_mid_plane():
    v = np.zeros((40, 40, 13), bool)
    v[4:-4, 4:-4, 2:11] = True  # 9 voxels thick: mid plane at z = 6
    d, _ = distance_and_features(v)
    s = unravel(ie_skeleton(d), v.shape)
    far_from_rim = (s[:, 0] >= 12) & (s[:, 0] < 28) & (s[:, 1] >= 12) & (s[:, 1] < 28)
    assert set(s[far_from_rim, 2]) == {6}
    assert far_from_rim.sum() == 16 * 16


def test_ima_skeleton_brute_force_rule():
    v = blob(seed=4)
    d, f = distance_and_features(v)
    s = set(ima_skeleton(v, f).tolist())
    brute = set()
    f = np.stack(np.unravel_index(f, v.shape))
    for x in np.argwhere(v):
        fx = f[(slice(None),) + tuple(x)]
        for e in [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]:
            y = x + e
            if not v[tuple(y)]:
                continue
            fy = f[(slice(None),) + tuple(y)]
            m = x + 0.5 * np.array(e)
            if np.sum((fy - fx) ** 2) > 1 and np.sum((m - fy) ** 2) <= np.sum((m - fx) ** 2):
                brute.add(int(np.ravel_multi_index(tuple(x), v.shape)))
                break
    assert s == brute


def test_extended_feature_points_brute_force():
    v = blob(seed=5)
    d, f = distance_and_features(v)
    s = ie_skeleton(d)
    a, b = (unravel(p, v.shape) for p in extended_feature_points(v, f, s))
    f = np.stack(np.unravel_index(f, v.shape))
    for i, x in enumerate(unravel(s, v.shape)):
        own = f[(slice(None),) + tuple(x)]
        assert np.array_equal(a[i], own)
        best = 0
        for o in OFFSETS_26:
            y = x + o
            if v[tuple(y)]:
                best = max(best, np.sum((f[(slice(None),) + tuple(y)] - own) ** 2))
        assert np.sum((b[i] - own) ** 2) == best
