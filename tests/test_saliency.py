"""Derivative measure and rho+ against brute force and hand-checked cases."""

import numpy as np

from skelfilter.core.neighbourhood import ravel, unravel
from skelfilter.core.saliency import derivative_measure, feature_velocity, rho_plus, skeleton_adjacency


def random_voxels(shape=(12, 13, 14), n=300, seed=0):
    rng = np.random.default_rng(seed)
    inner = np.argwhere(np.ones(tuple(s - 2 for s in shape), bool)) + 1
    pick = inner[rng.choice(len(inner), n, replace=False)]
    return np.sort(ravel(pick, shape))


def test_adjacency_matches_brute_force():
    shape = (12, 13, 14)
    s = random_voxels(shape)
    indptr, indices = skeleton_adjacency(s, shape)
    c = unravel(s, shape)
    cheb = np.abs(c[:, None, :] - c[None, :, :]).max(-1)
    brute = (cheb == 1)
    for i in range(len(s)):
        assert sorted(indices[indptr[i]:indptr[i + 1]].tolist()) == np.flatnonzero(brute[i]).tolist()


def brute_rho_plus_cone(rho, sigma, coords, velocity, adjacency_sets, k, min_cosine, min_rho):
    """Eq. 5.6 where a voxel only takes rho+ from visited neighbours ahead along v (cosine >= min_cosine).

    A zero velocity (or ``min_cosine = -inf``) lets every visited neighbour count: eq. 5.6 as printed.
    """
    order = sorted(range(len(rho)), key=lambda i: (-rho[i], i))
    out = {}
    for r, i in enumerate(order):
        if r == 0 or (not np.isnan(sigma[i]) and sigma[i] <= k):
            out[i] = rho[i]
            continue
        v = velocity[i].astype(np.float64)
        done = []
        for j in adjacency_sets[i]:
            if j not in out:
                continue
            step = (coords[j] - coords[i]).astype(np.float64)
            cosine = step @ v / (np.linalg.norm(step) * np.linalg.norm(v)) if v.any() else 1.0
            if rho[i] < min_rho or cosine >= min_cosine:
                done.append(out[j])
        out[i] = max(done) if done else rho[i]
    return np.array([out[i] for i in range(len(rho))], dtype=np.float32)


def _random_skeleton(shape, seed):
    """Skeleton voxels, their CSR and set adjacency, and random rho (many ties) and sigma_bar (some NaN)."""
    s = random_voxels(shape, n=500, seed=seed)
    indptr, indices = skeleton_adjacency(s, shape)
    rng = np.random.default_rng(seed + 1)
    rho = rng.integers(0, 30, len(s)).astype(np.float32)
    sigma = rng.normal(1.0, 1.0, len(s)).astype(np.float32)
    sigma[rng.random(len(s)) < 0.1] = np.nan
    adj = [set(indices[indptr[i]:indptr[i + 1]].tolist()) for i in range(len(s))]
    return s, indptr, indices, adj, rho, sigma, rng


def test_rho_plus_matches_recursion_of_eq_5_6():
    s, indptr, indices, adj, rho, sigma, _ = _random_skeleton((12, 13, 14), seed=1)
    got = rho_plus(rho, sigma, (indptr, indices), k=0.9)
    no_direction = np.zeros((len(s), 3))  # the literal eq. 5.6: every visited neighbour counts
    want = brute_rho_plus_cone(rho, sigma, no_direction, no_direction, adj, 0.9, -np.inf, 0.0)
    assert np.array_equal(got, want)
    assert (got >= rho).all()


def test_rho_plus_along_v_matches_brute_force():
    shape = (12, 13, 14)
    s, indptr, indices, adj, rho, sigma, rng = _random_skeleton(shape, seed=3)
    # integer velocities keep the cosines away from rounding ties at the cone's edge
    velocity = rng.integers(-3, 4, (len(s), 3)).astype(np.float32)
    velocity[rng.random(len(s)) < 0.05] = 0.0  # no direction: any neighbour
    coords = unravel(s, shape)
    for min_cosine, min_rho in ((0.5, 0.0), (0.5, 7.0), (0.0, 3.0)):
        got = rho_plus(rho, sigma, (indptr, indices), k=0.9, velocity=velocity, skeleton=s, shape=shape,
                       min_cosine=min_cosine, min_rho=min_rho)
        want = brute_rho_plus_cone(rho, sigma, coords, velocity, adj, 0.9, min_cosine, min_rho)
        assert np.array_equal(got, want)
        assert (got >= rho).all()
    # a cone that admits every direction is eq. 5.6 as printed
    wide = rho_plus(rho, sigma, (indptr, indices), k=0.9, velocity=velocity, skeleton=s, shape=shape,
                    min_cosine=-1.5)
    assert np.array_equal(wide, rho_plus(rho, sigma, (indptr, indices), k=0.9))


def _core_and_branch(shape, branch):
    """A core line along x at y = 5 whose rho grows towards +x, and ``branch`` voxels at rho 8."""
    coords = np.array([(x, 5, 2) for x in range(2, 25)] + branch)
    s = ravel(coords, shape)
    order = np.argsort(s)
    s, coords = s[order], coords[order]
    is_core = coords[:, 1] == 5
    return s, is_core, np.where(is_core, 10.0 + coords[:, 0], 8.0).astype(np.float32)


def test_rho_plus_along_v_stops_sideways_inheritance():
    # A core line along x whose importance grows to the root, and next to it
    # (one voxel over in y) a noise line of constant importance whose
    # derivative is undefined (NaN: never ligature) and whose v points away
    # from the core (+y). Eq. 5.6 as printed hands the core's rho+ sideways
    # to every noise voxel; along v the noise keeps its own importance.
    shape = (30, 12, 5)
    s, is_core, rho = _core_and_branch(shape, [(x, 6, 2) for x in range(5, 20)])
    sigma = np.where(is_core, 2.0, np.nan).astype(np.float32)
    v = np.where(is_core[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]).astype(np.float32)
    adj = skeleton_adjacency(s, shape)
    spread = rho_plus(rho, sigma, adj, k=0.9)
    assert np.all(spread == rho.max())
    along = rho_plus(rho, sigma, adj, k=0.9, velocity=v, skeleton=s, shape=shape)
    assert np.all(along[is_core] == rho.max())
    assert np.all(along[~is_core] == 8.0)
    # below min_rho v is not trusted: the noise line takes rho+ from any neighbour again
    small = rho_plus(rho, sigma, adj, k=0.9, velocity=v, skeleton=s, shape=shape, min_rho=9.0)
    assert np.all(small == rho.max())


def line_skeleton(shape, xs, y, z):
    return ravel(np.array([(x, y, z) for x in xs]), shape)


def test_rho_plus_separates_a_ligature_branch():
    # A core branch along x whose importance grows to the root, and a side
    # branch along y with constant importance (a ligature, sigma_bar = 0).
    shape = (30, 30, 5)
    s, is_core, rho = _core_and_branch(shape, [(15, y, 2) for y in range(6, 20)])
    sigma = np.where(is_core, 2.0, 0.0).astype(np.float32)
    rp = rho_plus(rho, sigma, skeleton_adjacency(s, shape), k=0.9)
    assert np.all(rp[is_core] == rho.max())
    assert np.all(rp[~is_core] == 8.0)
    kept = rp >= 18
    assert kept[is_core].all() and not kept[~is_core].any()


def sheet(shape, z):
    xs, ys = np.meshgrid(np.arange(3, shape[0] - 3), np.arange(3, shape[1] - 3), indexing="ij")
    c = np.stack([xs.ravel(), ys.ravel(), np.full(xs.size, z)], axis=1)
    return ravel(c, shape), c


def test_derivative_measure_on_sheets():
    shape = (20, 18, 9)
    s, c = sheet(shape, 4)
    x = np.arange(shape[0], dtype=np.float32)[:, None, None]
    distance = np.broadcast_to(x, shape).copy()  # D grows along x with unit slope
    v = np.tile(np.array([[1.0, 0.0, 0.0]], np.float32), (len(s), 1))
    adj = skeleton_adjacency(s, shape)
    interior = (c[:, 0] > 3) & (c[:, 0] < shape[0] - 4) & (c[:, 1] > 3) & (c[:, 1] < shape[1] - 4)
    # corner-like branch: rho = 2 D  ->  sigma_bar = 2
    sig = derivative_measure(2.0 * c[:, 0].astype(np.float32), distance, s, v, adj, guard=0.1)
    assert np.allclose(sig[interior], 2.0, atol=1e-2)
    # ligature: rho constant while D grows -> sigma_bar = 0
    sig = derivative_measure(np.full(len(s), 7.0, np.float32), distance, s, v, adj, guard=0.1)
    assert np.allclose(sig[interior], 0.0, atol=1e-6)
    # the sheet's rim ahead of v has no skeleton voxel to step to: undefined
    assert np.isnan(sig[c[:, 0] == c[:, 0].max()]).all()
    # v across the growth of D: the guard of eq. 4.3 leaves it undefined
    v_side = np.tile(np.array([[0.0, 1.0, 0.0]], np.float32), (len(s), 1))
    sig = derivative_measure(2.0 * c[:, 0].astype(np.float32), distance, s, v_side, adj, guard=0.1)
    assert np.isnan(sig).all()


def test_derivative_measure_is_undefined_where_the_step_reaches_the_cap():
    shape = (20, 18, 9)
    s, c = sheet(shape, 4)
    distance = np.broadcast_to(np.arange(shape[0], dtype=np.float32)[:, None, None], shape).copy()
    v = np.tile(np.array([[1.0, 0.0, 0.0]], np.float32), (len(s), 1))
    adj = skeleton_adjacency(s, shape)
    rho = np.minimum(2.0 * c[:, 0], 20.0).astype(np.float32)  # rho = 2 D, capped at 20 from x = 10 on
    free = derivative_measure(rho, distance, s, v, adj, guard=0.1)
    capped = derivative_measure(rho, distance, s, v, adj, guard=0.1, max_rho=20.0)
    interior = (c[:, 1] > 3) & (c[:, 1] < shape[1] - 4)
    assert np.allclose(free[interior & (c[:, 0] >= 10) & (c[:, 0] < shape[0] - 4)], 0.0)  # the cap looks like ligature
    assert np.isnan(capped[c[:, 0] >= 9]).all()  # steps that reach the cap: undefined
    before = interior & (c[:, 0] > 3) & (c[:, 0] < 9)
    np.testing.assert_array_equal(capped[before], free[before])
    assert np.allclose(capped[before], 2.0, atol=1e-2)


def test_derivative_measure_is_undefined_below_min_rho():
    shape = (20, 18, 9)
    s, c = sheet(shape, 4)
    distance = np.broadcast_to(np.arange(shape[0], dtype=np.float32)[:, None, None], shape).copy()
    v = np.tile(np.array([[1.0, 0.0, 0.0]], np.float32), (len(s), 1))
    adj = skeleton_adjacency(s, shape)
    rho = 2.0 * c[:, 0].astype(np.float32)  # 6 .. 32 across the sheet
    full = derivative_measure(rho, distance, s, v, adj, guard=0.1)
    cut = derivative_measure(rho, distance, s, v, adj, guard=0.1, min_rho=12.0)
    assert np.isnan(cut[rho < 12.0]).all()
    assert np.array_equal(cut[rho >= 12.0], full[rho >= 12.0], equal_nan=True)
    assert not np.isnan(full[(rho < 12.0) & (c[:, 0] < c[:, 0].max())]).any()


def test_derivative_ignores_off_skeleton_voxels():
    # rho only exists on the sheet; a voxel next to the sheet with "zero rho"
    # must not pull the gradient: result equals the sheet-only slope.
    shape = (20, 18, 9)
    s, c = sheet(shape, 4)
    distance = np.broadcast_to(np.arange(shape[0], dtype=np.float32)[:, None, None], shape).copy()
    v = np.tile(np.array([[1.0, 0.0, 0.5]], np.float32), (len(s), 1))
    sig = derivative_measure(3.0 * c[:, 0].astype(np.float32), distance, s, v, skeleton_adjacency(s, shape))
    interior = (c[:, 0] > 3) & (c[:, 0] < shape[0] - 4) & (c[:, 1] > 3) & (c[:, 1] < shape[1] - 4)
    assert np.allclose(sig[interior], 3.0, atol=1e-2)


def test_feature_velocity_is_eq_4_16():
    shape = (10, 10, 10)
    s = ravel(np.array([[5, 5, 5]]), shape)
    v = feature_velocity(s, shape, np.array([[2, 5, 2]]), np.array([[2, 5, 8]]))
    assert np.allclose(v, [[3, 0, 0]])
