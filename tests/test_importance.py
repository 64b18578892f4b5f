"""Importance measures against brute force: scipy's Dijkstra on an independently built graph."""

import itertools

import numba
import numpy as np
import pytest
from scipy import ndimage, sparse
from scipy.sparse import csgraph
from scipy.spatial import cKDTree

from skelfilter.core.decision.pruning_rules import search_cap
from skelfilter.core.importance import boundary_layer, euclidean_importance, geodesic_estimate, geodesic_importance
from skelfilter.errors import ParameterError


def _coords(n):
    return np.meshgrid(*(np.arange(n),) * 3, indexing="ij")


def ball_and_box():
    x, y, z = _coords(40)
    ball = (x - 20) ** 2 + (y - 20) ** 2 + (z - 20) ** 2 <= 100
    box = (x >= 4) & (x < 36) & (y >= 17) & (y < 23) & (z >= 6) & (z < 12)
    return ball | box


def torus():
    x, y, z = _coords(40)
    return (np.hypot(x - 19.5, y - 19.5) - 12) ** 2 + (z - 19.5) ** 2 <= 25


def blobs():
    # Several components, some cut by the volume's faces.
    noise = ndimage.gaussian_filter(np.random.default_rng(7).standard_normal((36, 36, 36)), 3, mode="wrap")
    return noise > 0.5 * noise.std()


def ball(n, radius):
    x, y, z = _coords(n)
    c = (n - 1) / 2
    return (x - c) ** 2 + (y - c) ** 2 + (z - c) ** 2 <= radius**2


def graph_geodesics(boundary, a, b):
    """Dijkstra over M's 26-graph: voxels within sqrt(3) of each other, weighted by their distance."""
    nodes = np.argwhere(boundary)
    tree = cKDTree(nodes)
    pairs = tree.query_pairs(np.sqrt(3) + 1e-6, output_type="ndarray")
    w = np.linalg.norm(nodes[pairs[:, 0]] - nodes[pairs[:, 1]], axis=1)
    g = sparse.coo_matrix((w, (pairs[:, 0], pairs[:, 1])), shape=(len(nodes),) * 2).tocsr()
    flat = np.flatnonzero(boundary)
    ia, ib = np.searchsorted(flat, a), np.searchsorted(flat, b)
    sources, row = np.unique(ia, return_inverse=True)
    return csgraph.dijkstra(g, directed=False, indices=sources)[row, ib]


def random_pairs(boundary, reach, n_sources=60, per_source=10, seed=0):
    """Pairs of M voxels, mostly within ``reach`` of each other."""
    rng = np.random.default_rng(seed)
    flat = np.flatnonzero(boundary)
    nodes = np.argwhere(boundary)
    tree = cKDTree(nodes)
    a, b = [], []
    for i in rng.choice(len(nodes), n_sources, replace=False):
        near = tree.query_ball_point(nodes[i], reach)
        far = rng.integers(0, len(nodes), 2)
        a += [flat[i]] * per_source
        b += list(flat[rng.choice(near, per_source - 2)]) + list(flat[far])
    return np.array(a), np.array(b)


@pytest.mark.parametrize("make", [ball_and_box, torus, blobs])
@pytest.mark.parametrize("cap", [20.0, 1000.0])
def test_geodesic_equals_dijkstra(make, cap):
    m = boundary_layer(make())
    a, b = random_pairs(m, reach=min(1.3 * cap, 40))
    rho, expanded = geodesic_importance(m, a, b, cap)
    truth = graph_geodesics(m, a, b)
    below = truth < cap - 1e-3
    assert below.sum() > 100
    np.testing.assert_allclose(rho[below], truth[below], rtol=0, atol=1e-4)
    assert np.all(rho[truth >= cap] == np.float32(cap))
    assert rho.dtype == np.float32 and expanded.dtype == np.int32
    if cap == 20.0:
        assert (truth >= cap).sum() > 50


def test_blobs_have_unreachable_pairs():
    # Guards the previous test: some pairs of the blobs lie in different components.
    m = boundary_layer(blobs())
    a, b = random_pairs(m, reach=40)
    assert np.isinf(graph_geodesics(m, a, b)).sum() > 20


def test_disconnected_components_give_cap_without_searching():
    x = np.zeros((40, 30, 30), dtype=bool)
    x[5:15, 10:20, 10:20] = True
    x[18:28, 10:20, 10:20] = True  # 3 empty voxels between: the two layers do not touch
    m = boundary_layer(x)
    shape = m.shape
    a = np.ravel_multi_index([[15], [12], [12]], shape)
    b = np.ravel_multi_index([[17], [12], [12]], shape)
    rho, expanded = geodesic_importance(m, a, b, 1000.0)
    assert rho[0] == 1000.0
    labels, _ = ndimage.label(m, structure=np.ones((3, 3, 3)))
    assert labels.reshape(-1)[a[0]] != labels.reshape(-1)[b[0]]
    # Components are labelled first: no search runs for a pair that cannot connect.
    assert expanded[0] == 0
    # ... while a pair inside one component is still searched.
    c = np.ravel_multi_index([[4], [12], [12]], shape)
    rho, expanded = geodesic_importance(m, a, c, 1000.0)
    assert 0 < rho[0] < 1000.0 and expanded[0] > 0


def test_identical_duplicate_and_swapped_pairs():
    m = boundary_layer(torus())
    a, b = random_pairs(m, reach=25, n_sources=20)
    rho, expanded = geodesic_importance(m, a, b, 24.0)
    both = geodesic_importance(m, np.r_[a, b, a, a], np.r_[b, a, b, a], 24.0)
    for value, again in zip((rho, expanded), both):
        n = len(a)
        assert np.array_equal(again[:n], value)
        assert np.array_equal(again[n : 2 * n], value)
        assert np.array_equal(again[2 * n : 3 * n], value)
    assert np.all(both[0][3 * n :] == 0) and np.all(both[1][3 * n :] == 0)


def test_expansions_only_where_a_search_ran():
    m = boundary_layer(ball_and_box())
    a, b = random_pairs(m, reach=40, per_source=20)
    a = np.r_[a, a[:30]]
    b = np.r_[b, a[:30]]
    cap = 18.0
    rho, expanded = geodesic_importance(m, a, b, cap)
    chord = euclidean_importance(m.shape, a, b)
    assert np.all(expanded[(a == b) | (chord >= cap)] == 0)
    assert np.all(rho[chord >= cap] == np.float32(cap))
    found = (a != b) & (rho < cap)
    assert found.sum() > 100 and np.all(expanded[found] >= 2)


def test_same_answer_on_any_number_of_threads():
    m = boundary_layer(blobs())
    a, b = random_pairs(m, reach=30)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = geodesic_importance(m, a, b, 25.0)
    finally:
        numba.set_num_threads(before)
    many = geodesic_importance(m, a, b, 25.0)
    assert np.array_equal(one[0], many[0]) and np.array_equal(one[1], many[1])


def test_geodesic_input_errors():
    m = boundary_layer(ball(20, 6))
    on = np.flatnonzero(m)[:2]
    off = np.flatnonzero(~m)[:2]
    with pytest.raises(ParameterError):
        geodesic_importance(m, on, on, 0.0)
    with pytest.raises(ParameterError):
        geodesic_importance(m, on, off, 10.0)
    with pytest.raises(ParameterError):
        geodesic_importance(m, on, on[:1], 10.0)
    rho, expanded = geodesic_importance(m, on[:0], on[:0], 10.0)
    assert rho.shape == expanded.shape == (0,)


def test_estimate_is_euclidean_on_a_flat_face():
    x = np.zeros((40, 40, 40), dtype=bool)
    x[8:32, 8:32, 16:24] = True
    d = ndimage.distance_transform_edt(x).astype(np.float32)
    m = boundary_layer(x)
    face = np.c_[np.argwhere(m[:, :, 24]), np.full(m[:, :, 24].sum(), 24)]
    rng = np.random.default_rng(3)
    a = np.ravel_multi_index(face[rng.integers(0, len(face), 300)].T, x.shape)
    b = np.ravel_multi_index(face[rng.integers(0, len(face), 300)].T, x.shape)
    est = geodesic_estimate(d, a, b)
    np.testing.assert_allclose(est, euclidean_importance(x.shape, a, b), rtol=1e-5)
    assert est.dtype == np.float32


def test_estimate_on_a_ball_lies_between_euclidean_and_graph_geodesic():
    x = ball(40, 14)
    d = ndimage.distance_transform_edt(x).astype(np.float32)
    m = boundary_layer(x)
    a, b = random_pairs(m, reach=22, n_sources=60)
    keep = a != b
    a, b = a[keep], b[keep]
    est = geodesic_estimate(d, a, b)
    chord = euclidean_importance(x.shape, a, b)
    truth = graph_geodesics(m, a, b)
    assert np.all(est >= chord * (1 - 1e-6))
    assert np.abs(est - truth).mean() < np.abs(chord - truth).mean()
    assert np.all(geodesic_estimate(d, a, a) == 0)


def test_euclidean_importance():
    shape = (5, 6, 7)
    a = np.ravel_multi_index([[0, 1], [0, 2], [0, 3]], shape)
    b = np.ravel_multi_index([[3, 1], [4, 2], [0, 3]], shape)
    out = euclidean_importance(shape, a, b)
    assert out.dtype == np.float32
    assert out.tolist() == [5.0, 0.0]


def test_boundary_layer_matches_its_definition():
    x = np.random.default_rng(1).random((12, 11, 10)) < 0.15
    m = boundary_layer(x)
    expected = np.zeros_like(x)
    for i, j, k in itertools.product(*map(range, x.shape)):
        if not x[i, j, k]:
            expected[i, j, k] = x[max(i - 1, 0) : i + 2, max(j - 1, 0) : j + 2, max(k - 1, 0) : k + 2].any()
    assert m.dtype == bool
    assert np.array_equal(m, expected)


def test_same_geodesics_as_one_search_per_pair_with_less_effort():
    """The packed-key heap, the pairs that failed searches cover and the landmarks' bound give the
    lengths of the (f, g)-pair heap searching every pair (commit cec1a4b) on a benchmark grid, noisy
    fandisk at 96 with the default cap, settling fewer nodes (5 395 611 then, 5.11-5.13 M with the
    grid's bound alone, 2.00 M with the landmarks')."""
    import hashlib

    from skelfilter.core import skeleton
    from skelfilter.core.distance import distance_and_features
    from skelfilter.io import mesh_files, samples
    from skelfilter.mesh import pipeline as mesh_pipeline
    from skelfilter.params import DenoiseParams

    _, noise, _ = mesh_pipeline.noisy_mesh(mesh_files.load_mesh(samples.sample_path("fandisk")), resolution=96,
                                           seed=3)
    occupancy = noise.noisy
    distance, features = distance_and_features(occupancy)
    voxels = skeleton.ie_skeleton(distance)
    a, b = skeleton.extended_feature_points(occupancy, features, voxels)
    rho, expanded = geodesic_importance(boundary_layer(occupancy), a, b, search_cap(DenoiseParams(resolution=96)))
    assert len(voxels) == 62520
    assert hashlib.sha256(rho.tobytes()).hexdigest()[:16] == "0f7647461ca1c999"
    assert expanded.sum() <= 0.4 * 5_395_611


def test_two_hop_cover_keeps_the_lengths():
    """From a cap of 32 a failed search covers the pairs two edges from its ends: they must still be
    the capped Dijkstra lengths, and some pairs the chord allows must go unsearched."""
    from skelfilter.core.geodesic_search import hops_for

    cap = 34.0
    assert hops_for(cap) == 2 and hops_for(26.0) == 1
    m = boundary_layer(torus())
    nodes = np.argwhere(m)
    flat = np.flatnonzero(m)
    tree = cKDTree(nodes)
    rng = np.random.default_rng(3)
    a, b = [], []
    # Clusters of pairs around far-apart ends (half way round the torus and less), as neighbouring
    # skeleton voxels give.
    for i in rng.choice(len(nodes), 40, replace=False):
        ends = tree.query_ball_point(nodes[i], 40)
        j = rng.choice(ends)
        near_a = tree.query_ball_point(nodes[i], 2 * np.sqrt(3) + 1e-6)
        near_b = tree.query_ball_point(nodes[j], 2 * np.sqrt(3) + 1e-6)
        for p in rng.choice(near_a, 8):
            a += [flat[p]] * 8
            b += list(flat[rng.choice(near_b, 8)])
    a, b = np.array(a), np.array(b)
    rho, expanded = geodesic_importance(m, a, b, cap)
    truth = graph_geodesics(m, a, b)
    below = truth < cap - 1e-3
    assert below.sum() > 100 and (truth >= cap).sum() > 100
    np.testing.assert_allclose(rho[below], truth[below], rtol=0, atol=1e-4)
    assert np.all(rho[truth >= cap] == np.float32(cap))
    covered = (expanded == 0) & (a != b) & (euclidean_importance(m.shape, a, b) < cap) & (truth >= cap)
    assert covered.sum() > 20


@pytest.mark.parametrize("make", [torus, blobs])
def test_landmark_distances_are_dijkstras_and_their_bound_holds(make):
    """Each landmark's lengths are scipy's Dijkstra's (inf in other components), and the bound the
    searches read, |d(L, b) - d(L, u)| less the slack, never exceeds the true length."""
    from skelfilter.core import importance
    from skelfilter.core.geodesic_landmarks import DIRECTIONS, landmark_distances

    m = boundary_layer(make())
    coords = np.argwhere(m).astype(np.int32)
    indptr, indices, steps = importance._graph(m, coords)
    distances, slack = landmark_distances(indptr, indices, steps, coords)
    assert distances.dtype == np.float32 and 0 < distances.shape[1] <= len(DIRECTIONS)
    lengths = np.array([0.0, 1.0, np.sqrt(2), np.sqrt(3)])[steps]
    graph = sparse.csr_matrix((lengths, indices, indptr), shape=(len(coords),) * 2)
    seeds = np.argmin(distances, axis=0)  # each landmark is at length 0 from itself
    truth = csgraph.dijkstra(graph, indices=seeds).T
    assert np.array_equal(np.isinf(truth), np.isinf(distances))
    finite = np.isfinite(truth)
    np.testing.assert_allclose(distances[finite], truth[finite], rtol=2**-23, atol=0)
    rng = np.random.default_rng(1)
    u, t = rng.integers(0, len(coords), (2, 4000))
    pair = csgraph.dijkstra(graph, indices=np.unique(t))[np.searchsorted(np.unique(t), t), u]
    with np.errstate(invalid="ignore"):
        bound = np.abs(distances[t] - distances[u]) - slack
    bound = np.where(np.isnan(bound), 0.0, bound).max(axis=1)
    reachable = np.isfinite(pair)
    assert reachable.sum() > 1000
    assert np.all(bound[reachable] <= pair[reachable])
