"""Implicit minification (thesis §6.2.1) against brute force, its bounds, and corner cutting."""

import numpy as np
import pytest
from scipy import ndimage as ndi

from skelfilter.core.edt_filters import minify
from skelfilter.core.reconstruct import reconstruction, reverse_edt
from skelfilter.errors import ParameterError


def _blob(shape, seed, sigma=2.0, level=0.0):
    noise = np.random.default_rng(seed).standard_normal(shape)
    return ndi.gaussian_filter(noise, sigma) > level


def _brute_minify(distance, centres, radius):
    x = np.stack(np.unravel_index(np.arange(distance.size), distance.shape), axis=1)
    c = np.stack(np.unravel_index(centres, distance.shape), axis=1)
    d = distance.ravel()
    out = np.empty(centres.size)
    for n in range(centres.size):
        near = (((x - c[n]) ** 2).sum(axis=1) <= radius**2 + 1e-9) & (d > 0)
        inf = d[near].min() if near.any() else 0.0
        out[n] = inf + radius if d[centres[n]] >= radius else inf
        if d[centres[n]] <= 0:  # eq. 6.1's "otherwise": a centre outside X
            out[n] = 0.0
    return out.astype(np.float32)


@pytest.mark.parametrize("radius", [0.0, 1.0, 1.5, 2.0, 3.0, 4.2])
def test_matches_brute_force(radius):
    x = _blob((22, 18, 20), seed=3)  # touches the volume border
    distance = ndi.distance_transform_edt(x).astype(np.float32)
    rng = np.random.default_rng(0)
    centres = np.concatenate([rng.choice(np.flatnonzero(x), 150, replace=False), rng.integers(0, x.size, 20)])
    np.testing.assert_array_equal(minify(distance, centres, radius), _brute_minify(distance, centres, radius))


def test_arbitrary_field_matches_brute_force():
    rng = np.random.default_rng(1)
    distance = rng.uniform(0, 5, (12, 14, 13)) * (rng.random((12, 14, 13)) < 0.7)
    centres = rng.integers(0, distance.size, 100)
    np.testing.assert_allclose(minify(distance, centres, 2.5), _brute_minify(distance, centres, 2.5), rtol=1e-6)


def test_radius_zero_gives_distance_back():
    x = _blob((20, 20, 20), seed=4)
    distance = ndi.distance_transform_edt(x)
    centres = np.flatnonzero(x)
    np.testing.assert_array_equal(minify(distance, centres, 0), distance.ravel()[centres].astype(np.float32))


@pytest.mark.parametrize("radius", [1.0, 2.0, 3.0, 4.5])
def test_bounds_from_lipschitz_edt(radius):
    # D is 1-Lipschitz and >= 1 on X, so D - r <= D_inf <= D and D_inf >= 1. Hence
    # D >= r: max(D, 1 + r) <= minf <= D + r;   D < r: max(D - r, 1) <= minf <= D.
    x = _blob((30, 30, 30), seed=5)
    distance = ndi.distance_transform_edt(x)
    centres = np.flatnonzero(x)
    d = distance.ravel()[centres]
    m = minify(distance, centres, radius).astype(np.float64)
    tol = 1e-5 * (1 + d)
    deep = d >= radius
    assert np.all(m[deep] >= np.maximum(d[deep], 1 + radius) - tol[deep])
    assert np.all(m[deep] <= d[deep] + radius + tol[deep])
    assert np.all(m[~deep] >= np.maximum(d[~deep] - radius, 1) - tol[~deep])
    assert np.all(m[~deep] <= d[~deep] + tol[~deep])
    assert np.any(m[~deep] < d[~deep]) or radius <= 1  # shallow centres shrink (none when r <= 1)


def test_border_is_clipped_like_background_padding():
    x = _blob((16, 18, 20), seed=6)
    x[0], x[:, -1] = True, True
    distance = ndi.distance_transform_edt(x)
    centres = np.flatnonzero(x)
    padded = np.pad(distance, 4)
    shifted = np.ravel_multi_index(tuple(np.array(np.unravel_index(centres, x.shape)) + 4), padded.shape)
    np.testing.assert_array_equal(minify(distance, centres, 3.0), minify(padded, shifted, 3.0))


def test_centres_outside_the_shape_get_zero():
    distance = np.zeros((8, 8, 8))
    distance[2:6, 2:6, 2:6] = 1.0
    assert minify(distance, [0, 7], 3.0).tolist() == [0.0, 0.0]
    assert minify(distance, np.array([], np.int64), 3.0).shape == (0,)


def test_invalid_parameters():
    distance = np.ones((4, 4, 4))
    for radius in (-1.0, np.nan, np.inf):
        with pytest.raises(ParameterError):
            minify(distance, [0], radius)
    with pytest.raises(ParameterError):
        minify(distance, [64], 1.0)
    with pytest.raises(ParameterError):
        minify(np.ones((4, 4)), [0], 1.0)


@pytest.fixture(scope="module")
def cube():
    """A 40^3 cube (4 voxels of padding), its EDT and IE-like centres (eq. 7.7, E >= 1)."""
    n, pad = 40, 4
    x = np.zeros((n + 2 * pad,) * 3, bool)
    x[pad:-pad, pad:-pad, pad:-pad] = True
    distance = ndi.distance_transform_edt(x)
    grad2 = sum(g**2 for g in np.gradient(distance))
    ie = x & (distance * np.sqrt(np.clip(1 - grad2, 0, None)) >= 1)
    # Distance of every voxel to its 1st, 2nd, 3rd nearest cube face.
    i = np.indices(x.shape) - pad
    faces = np.sort(np.minimum(i, n - 1 - i), axis=0)
    return x, distance, np.flatnonzero(ie), faces


def test_cube_radii_shrink_along_edges_not_under_faces(cube):
    x, distance, centres, faces = cube
    d = distance.ravel()[centres]
    ratio = minify(distance, centres, 3.0) / d
    # The deep centres, whose balls make the faces, keep their radius exactly:
    # on the cube's integer EDT the +r correction undoes the infimum where D >= r + 1.
    assert np.all(ratio[d >= 4] == 1)
    # The shallow ones, which only exist along edges (and so at corners), shrink by up to half.
    shallow = d < 3
    assert np.all(faces[1].ravel()[centres][shallow] < 3)
    assert np.all(ratio[shallow] <= 1) and ratio.min() == 0.5
    # D in [r, r + 1) overshoots to 1 + r, because D_inf >= 1 on X.
    assert np.all(ratio[(d >= 3) & (d < 4)] == 4 / 3)


def test_cube_reconstruction_loses_only_corner_voxels(cube):
    x, distance, centres, faces = cube
    assert np.array_equal(reconstruction(reverse_edt(x.shape, centres, distance.ravel()[centres])[0]), x)
    corner_region = faces[2] < 6
    lost = {}
    for radius in (3.0, 4.0, 5.0):
        rebuilt = reconstruction(reverse_edt(x.shape, centres, minify(distance, centres, radius))[0])
        missing = x & ~rebuilt
        assert not np.any(missing & ~corner_region)
        lost[radius] = int(missing.sum())
        added = rebuilt & ~x
        # The overshoot of D in [r, r + 1) adds one layer outside, only within r + 2 of an edge.
        assert np.all(faces[0][added] == -1) and np.all(faces[1][added] <= radius + 2)
    assert lost == {3.0: 0, 4.0: 8, 5.0: 56}
    four = reconstruction(reverse_edt(x.shape, centres, minify(distance, centres, 4.0))[0])
    assert np.array_equal(np.argwhere(x & ~four), np.argwhere(x & (faces[2] == 0) & (faces[1] == 0) & (faces[0] == 0)))


def test_needles_peels_voxel_thin_spikes_and_nothing_of_a_solid():
    from skelfilter.core.edt_filters import needles

    x = np.zeros((30, 30, 30), bool)
    x[5:25, 5:25, 5:15] = True
    x[12, 12, 15:22] = True  # a spike one voxel wide, seven long
    x[18, 8, 15] = x[19, 9, 16] = True  # a diagonal stub of two
    spikes = needles(x)
    expected = np.zeros_like(x)
    expected[12, 12, 16:22] = True  # its foot has the slab below it as neighbours and stays
    expected[19, 9, 16] = True
    assert np.array_equal(spikes, expected)
    assert not needles(x & ~spikes).any()  # a second pass finds nothing
