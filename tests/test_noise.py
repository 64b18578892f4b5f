import numpy as np
import pytest
from scipy import ndimage

from skelfilter.core.synthetic_noise import NoiseResult, add_noise
from skelfilter.errors import InputError, ParameterError

H, R = 3, 2.1
CUBE = np.ones((3, 3, 3), bool)


def box(side=60, pad=12):
    x = np.zeros((side + 2 * pad,) * 3, bool)
    x[pad:-pad, pad:-pad, pad:-pad] = True
    return x


def ball(radius=22, pad=12):
    n = 2 * (radius + pad)
    g = np.indices((n, n, n)) - (n - 1) / 2
    return (g**2).sum(axis=0) < radius**2


BOX = box()
BALL = ball()


def boundary_layer(x):
    return ndimage.binary_dilation(x, CUBE) & ~x  # eq. 7.12


def test_zero_incidence_leaves_the_volume_unchanged():
    res = add_noise(BOX, p=0.0, dents=True)
    assert isinstance(res, NoiseResult)
    assert np.array_equal(res.noisy, BOX) and np.array_equal(res.clean, BOX)
    assert not res.bumps.any() and not res.dents.any()
    assert res.sites.shape == (0, 3) and res.sites.dtype == np.int64


def test_same_seed_same_result_other_seed_other_result():
    a, b = add_noise(BOX, seed=3, dents=True), add_noise(BOX, seed=3, dents=True)
    assert np.array_equal(a.noisy, b.noisy) and np.array_equal(a.sites, b.sites)
    c = add_noise(BOX, seed=4, dents=True)
    assert not np.array_equal(a.noisy, c.noisy)


@pytest.mark.parametrize("shape", [BOX, BALL], ids=["box", "ball"])
def test_protrusions_stay_within_reach_and_reach_their_height(shape):
    res = add_noise(shape, seed=1, dents=True)
    outside, inside = ndimage.distance_transform_edt(~shape), ndimage.distance_transform_edt(shape)
    # A site lies in X ⊕ b, up to sqrt(3) from X at corners; a swept sphere adds h + r.
    assert outside[res.bumps].max() < H + R + np.sqrt(3)
    assert inside[res.dents].max() < H + R + np.sqrt(3)
    # Inward-pointing normals would leave only the h' = 0 sphere, about r + 1 deep.
    assert outside[res.bumps].max() >= H + R and inside[res.dents].max() >= H + R


def test_sites_are_an_incidence_p_sample_of_the_boundary_layer():
    layer = boundary_layer(BOX)
    p = 0.05
    mean, sd = p * layer.sum(), np.sqrt(p * (1 - p) * layer.sum())
    for seed in range(5):
        res = add_noise(BOX, p=p, l=1, seed=seed)
        assert abs(len(res.sites) - mean) < 4 * sd
        assert layer[tuple(res.sites.T)].all() and res.bumps[tuple(res.sites.T)].all()
        assert len(np.unique(res.sites, axis=0)) == len(res.sites)


def test_zero_d_noise_gives_one_bump_per_site():
    for seed in range(3):
        res = add_noise(BOX, p=0.001, l=1, seed=seed)
        _, count = ndimage.label(res.bumps, CUBE)
        # Each sweep is connected and holds its site; only nearby sites merge.
        assert 0.8 * len(res.sites) <= count <= len(res.sites)


def footprint_elongations(bumps):
    """sqrt of the ratio of principal variances of each bump's footprint on the box's top face."""
    top = bumps[12:72, 12:72, 72]
    labels, _ = ndimage.label(top, np.ones((3, 3), bool))
    ratios = []
    for i, (sx, sy) in enumerate(ndimage.find_objects(labels), 1):
        if min(sx.start, sy.start) > 0 and max(sx.stop, sy.stop) < top.shape[0]:
            var = np.linalg.eigvalsh(np.cov(np.argwhere(labels == i).T.astype(float)))
            ratios.append(np.sqrt(var[1] / var[0]))
    return np.array(ratios)


def test_walks_draw_elongated_stripes():
    def elongations(l):
        return np.concatenate([footprint_elongations(add_noise(BOX, p=0.003, l=l, seed=s).bumps) for s in (0, 1)])

    dots, stripes = elongations(1), elongations(6)
    assert len(dots) >= 8 and len(stripes) >= 6
    assert dots.mean() < 1.35 and stripes.mean() > 1.6


def test_bump_volume_grows_with_height():
    bumps = [add_noise(BOX, h=h, seed=2).bumps for h in (0, 1, 2, 3, 5)]
    for low, high in zip(bumps, bumps[1:]):
        assert high.sum() > low.sum() and not (low & ~high).any()


def test_dents_are_carved_after_the_bumps():
    plain = add_noise(BOX, seed=5)
    res = add_noise(BOX, seed=5, dents=True)
    assert res.dents.any() and res.bumps.any()
    assert not (res.bumps & res.clean).any() and not (res.dents & ~res.clean).any()
    assert np.array_equal(res.noisy, (res.clean | res.bumps) & ~res.dents)
    # The dent sites continue the bump stream, so the bumps are drawn identically.
    n = len(plain.sites)
    assert np.array_equal(res.sites[:n], plain.sites) and len(res.sites) > n
    assert not (res.bumps & ~plain.bumps).any()
    inner = BOX & ~ndimage.binary_erosion(BOX, CUBE)
    assert inner[tuple(res.sites[n:].T)].all()


def test_protrusions_near_the_border_raise():
    with pytest.raises(ParameterError, match="border"):
        add_noise(box(side=10, pad=4), p=0.5)
    # Padding by ceil(h + r + 2) is enough even with every surface voxel a site.
    res = add_noise(box(side=10, pad=int(np.ceil(H + R + 2))), p=1.0, dents=True)
    assert res.bumps.any()


@pytest.mark.parametrize(
    "kwargs", [{"p": -0.1}, {"p": 1.5}, {"r": 0}, {"r": -1}, {"h": -1}, {"l": 0}, {"l": 2.5}]
)
def test_bad_parameters_raise(kwargs):
    with pytest.raises(ParameterError):
        add_noise(BOX, **kwargs)


def test_non_volume_input_raises():
    with pytest.raises(InputError):
        add_noise(np.ones((8, 8), bool))
