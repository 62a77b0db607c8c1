"""Threshold-free cluster enhancement: MNE-Python, closed forms, invariances, bad input."""

import numpy as np
import pytest
import scipy.sparse as sp
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.sparse.csgraph import connected_components

from ladders.statistics.tfce import mesh_adjacency, tfce, tfce_enhancer, tfce_step

SPHERE = trimesh.creation.icosphere(subdivisions=3)  # 642 vertices
SMALL = trimesh.creation.icosphere(subdivisions=1)  # 42 vertices
K = len(SPHERE.vertices)
ADJ = mesh_adjacency(SPHERE.faces, K)
SMALL_ADJ = mesh_adjacency(SMALL.faces, len(SMALL.vertices))


def smooth_maps(m, seed=0, scale=2.9876, adj=ADJ, iterations=8):
    """Random maps smoothed by neighbour averaging, scaled to a peak ``scale`` (not a threshold)."""
    x = np.random.default_rng(seed).standard_normal((m, adj.shape[0]))
    mean = sp.diags(1.0 / np.asarray(adj.sum(axis=1)).ravel()) @ adj
    for _ in range(iterations):
        x = 0.5 * x + 0.5 * (mean @ x.T).T
    return scale * x / np.abs(x).max(axis=1, keepdims=True)


def brute_force(x, adj, dh, height, extent, areas=None):
    """The Riemann sum threshold by threshold, with scipy's connected components.

    A value reaches the threshold ``j dh`` when ``x / dh >= j - 1e-9`` (rounding of ``j dh``).
    """
    w = np.ones(x.size) if areas is None else areas
    out = np.zeros(x.size)
    j = 1
    while x.max() / dh + 1e-9 >= j:
        on = np.flatnonzero(x / dh + 1e-9 >= j)
        _, labels = connected_components(adj[on][:, on], directed=False)
        sizes = np.bincount(labels, weights=w[on])
        out[on] += sizes[labels] ** extent * (j * dh) ** height * dh
        j += 1
    return out


def path_adjacency(n):
    return mesh_adjacency(np.zeros((0, 3), dtype=int), n) + sp.diags(
        [np.ones(n - 1), np.ones(n - 1)], [-1, 1], format="csr"
    )


# --- against MNE-Python ------------------------------------------------------------------


@pytest.mark.parametrize("extent", [0.5, 1.0])
@pytest.mark.parametrize("tail", [1, 0])
def test_equals_mne_permutation_cluster_tfce(tail, extent):
    mne = pytest.importorskip("mne")
    from mne.stats import permutation_cluster_1samp_test, ttest_1samp_no_p

    rng = np.random.default_rng(3)
    signal = smooth_maps(1, seed=4, scale=1.0)[0]
    data = 0.8 * signal + smooth_maps(12, seed=5, scale=2.0)
    data += 0.05 * rng.standard_normal(data.shape)
    t = ttest_1samp_no_p(data)
    step = 0.05
    adjacency = mne.spatial_tris_adjacency(SPHERE.faces)
    threshold = {"start": 0.0, "step": step, "h_power": 2.0, "e_power": extent}
    t_obs, *_ = permutation_cluster_1samp_test(
        data, threshold=threshold, adjacency=adjacency, tail=tail, n_permutations=4,
        seed=0, out_type="indices", verbose=False,
    )  # fmt: skip
    ours = tfce(t, adjacency, height=2.0, extent=extent, step=step, two_sided=tail == 0)
    assert np.abs(t).max() > 10 * step and np.count_nonzero(ours) > K // 4  # not trivial
    np.testing.assert_allclose(ours, t_obs, rtol=0, atol=1e-8)


def test_equals_mne_find_clusters_default_exponents():
    mne = pytest.importorskip("mne")
    from mne.stats.cluster_level import _find_clusters

    x = smooth_maps(1, seed=7)[0]
    adjacency = mne.spatial_tris_adjacency(SPHERE.faces)
    _, scores = _find_clusters(x, {"start": 0, "step": 0.1}, tail=1, adjacency=adjacency)
    np.testing.assert_allclose(tfce(x, ADJ, 2.0, 0.5, step=0.1), scores, rtol=0, atol=1e-8)


def test_equals_brute_force_with_areas():
    x = smooth_maps(1, seed=8)[0]
    areas = trimesh.triangles.area(SPHERE.triangles)
    vertex_areas = np.bincount(SPHERE.faces.ravel(), np.repeat(areas / 3, 3), minlength=K)
    ours = tfce(x, ADJ, step=0.07, areas=vertex_areas)
    np.testing.assert_allclose(ours, brute_force(x, ADJ, 0.07, 2.0, 1.0, vertex_areas), atol=1e-10)


# --- closed forms -------------------------------------------------------------------------


def test_isolated_vertex_and_plateau():
    dh, x, height = 0.1, 1.05, 2.0
    single = sum((j * dh) ** height * dh for j in range(1, 11))  # thresholds 0.1 ... 1.0
    assert single == pytest.approx(0.385, rel=1e-12)
    values = np.array([x, 0.0, x, x, x, x])  # vertex 0 alone; vertices 2..5 a plateau
    adj = path_adjacency(6)
    for extent in (0.5, 1.0, 2.0):
        out = tfce(values, adj, height, extent, step=dh)
        np.testing.assert_allclose(out, [single, 0, *[4**extent * single] * 4], rtol=1e-12)


def test_path_with_increasing_values():
    adj = path_adjacency(3)
    values = np.array([1.0, 2.0, 3.0])
    # h = 1: {0, 1, 2}, size 3; h = 2: {1, 2}, size 2; h = 3: {2}, size 1
    np.testing.assert_allclose(tfce(values, adj, 2.0, 1.0, step=1.0), [3, 3 + 8, 3 + 8 + 9])
    r3, r2 = np.sqrt(3), np.sqrt(2)
    np.testing.assert_allclose(
        tfce(values, adj, 1.0, 0.5, step=1.0), [r3, r3 + 2 * r2, r3 + 2 * r2 + 3]
    )
    twice = tfce(-values, adj, 2.0, 1.0, step=1.0, two_sided=True)
    np.testing.assert_allclose(twice, [-3, -11, -20])
    assert not tfce(-values, adj, 2.0, 1.0, step=1.0).any()


def test_automatic_step_gives_the_peak_all_its_strips():
    # an isolated vertex at the maximum x, dh = x / n: sum over j = 1..n of (j x / n)^H x / n
    n = 100
    for x in np.linspace(0.1, 20.0, 397):
        expected = sum((j * x / n) ** 2 * x / n for j in range(1, n + 1))
        out = tfce(np.array([x, 0.0, -x]), sp.csr_matrix((3, 3)), n_steps=n, two_sided=True)
        np.testing.assert_allclose(out, [expected, 0, -expected], rtol=1e-12)


def test_extent_zero_is_a_function_of_the_value_only():
    x = smooth_maps(1, seed=9)[0]
    dh = 0.1
    levels = np.floor(np.maximum(x, 0) / dh + 1e-9).astype(int)
    expected = [sum((j * dh) ** 2 * dh for j in range(1, n + 1)) for n in levels]
    np.testing.assert_allclose(tfce(x, ADJ, 2.0, 0.0, step=dh), expected, rtol=1e-12)
    no_edges = sp.csr_matrix((K, K))
    np.testing.assert_allclose(tfce(x, no_edges, 2.0, 0.0, step=dh), expected, rtol=1e-12)


def test_automatic_step_is_per_map_and_enhancer_fixes_it():
    maps = smooth_maps(3, seed=10) * np.array([[1.0], [2.0], [0.5]])
    auto = tfce(maps, ADJ, n_steps=50)
    for row, out in zip(maps, auto):
        np.testing.assert_allclose(out, tfce(row, ADJ, step=row.max() / 50), rtol=1e-12)
    dh = tfce_step(maps[0], n_steps=50, two_sided=True)
    assert dh == pytest.approx(np.abs(maps[0]).max() / 50)
    enhance = tfce_enhancer(ADJ, 2.0, 0.5, step=dh, two_sided=True)
    np.testing.assert_array_equal(enhance(maps), tfce(maps, ADJ, 2.0, 0.5, step=dh, two_sided=True))
    assert enhance(maps).shape == maps.shape
    assert not tfce(-np.abs(maps), ADJ).any()  # nothing positive: zero, not an error


# --- invariances --------------------------------------------------------------------------


def test_relabelled_mesh_permutes_the_result():
    rng = np.random.default_rng(11)
    q = rng.permutation(K)  # vertex v becomes q[v]
    x = smooth_maps(2, seed=12)
    relabelled = mesh_adjacency(q[SPHERE.faces], K)
    y = np.empty_like(x)
    y[:, q] = x
    for two_sided in (False, True):
        a = tfce(x, ADJ, step=0.05, two_sided=two_sided)
        b = tfce(y, relabelled, step=0.05, two_sided=two_sided)
        np.testing.assert_allclose(b[:, q], a, rtol=1e-12, atol=1e-12)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), m=st.integers(1, 6), two_sided=st.booleans(),
       extent=st.sampled_from([0.0, 0.5, 1.0, 2.0]))  # fmt: skip
def test_batch_equals_loop(seed, m, two_sided, extent):
    maps = smooth_maps(m, seed=seed, adj=SMALL_ADJ, iterations=2)
    batch = tfce(maps, SMALL_ADJ, extent=extent, step=0.1, two_sided=two_sided)
    loop = [tfce(row, SMALL_ADJ, extent=extent, step=0.1, two_sided=two_sided) for row in maps]
    np.testing.assert_array_equal(batch, np.array(loop))


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), vertex=st.integers(0, 41),
       increase=st.floats(1e-3, 3.0), extent=st.sampled_from([0.0, 0.5, 1.0, 2.0]))  # fmt: skip
def test_increasing_a_value_never_decreases_tfce(seed, vertex, increase, extent):
    x = smooth_maps(1, seed=seed, adj=SMALL_ADJ, iterations=1)[0]
    before = tfce(x, SMALL_ADJ, extent=extent, step=0.1)
    x[vertex] += increase
    after = tfce(x, SMALL_ADJ, extent=extent, step=0.1)
    assert (after >= before - 1e-12 * max(1.0, before.max())).all()
    np.testing.assert_allclose(after, brute_force(x, SMALL_ADJ, 0.1, 2.0, extent), atol=1e-10)


# --- the adjacency and bad input ----------------------------------------------------------


def test_mesh_adjacency():
    assert (ADJ != ADJ.T).nnz == 0 and ADJ.diagonal().sum() == 0
    assert ADJ.nnz == 2 * (3 * K - 6)  # closed genus-0 mesh: E = 3V - 6
    assert set(np.unique(ADJ.data)) == {1.0}
    np.testing.assert_array_equal(
        (ADJ != 0).toarray(), (sp.csr_matrix(SPHERE.edges_sparse) != 0).toarray()
    )


@pytest.mark.parametrize(
    "faces, n, match",
    [(np.zeros((4, 2), dtype=int), 5, "faces"), (np.zeros((4, 3)), 5, "faces"),
     (np.array([[0, 1, 5]]), 5, "faces"), (np.array([[0, -1, 2]]), 5, "faces"),
     (np.array([[0, 1, 2]]), 0, "n_vertices")],
)  # fmt: skip
def test_mesh_adjacency_bad_input(faces, n, match):
    with pytest.raises(ValueError, match=match):
        mesh_adjacency(faces, n)


def test_bad_input_names_the_argument():
    x = smooth_maps(1)[0]
    bad = x.copy()
    bad[3] = np.nan
    cases = [
        (lambda: tfce(bad, ADJ), "maps"),
        (lambda: tfce(np.ones((2, 2, K)), ADJ), "maps"),
        (lambda: tfce(x, ADJ[:-1, :-1]), "adjacency"),
        (lambda: tfce(x, np.ones(K)), "adjacency"),
        (lambda: tfce(x, ADJ, step=-0.1), "step"),
        (lambda: tfce(x, ADJ, step=0.0), "step"),
        (lambda: tfce(x, ADJ, step=1e-12), "step"),
        (lambda: tfce(x, ADJ, n_steps=0), "n_steps"),
        (lambda: tfce(x, ADJ, height=-1.0), "height"),
        (lambda: tfce(x, ADJ, extent=-0.5), "extent"),
        (lambda: tfce(x, ADJ, extent=np.nan), "extent"),
        (lambda: tfce(x, ADJ, areas=np.ones(K - 1)), "areas"),
        (lambda: tfce(x, ADJ, areas=-np.ones(K)), "areas"),
        (lambda: tfce_enhancer(ADJ, step=-1.0), "step"),
        (lambda: tfce_enhancer(ADJ, step=0.1)(np.ones((2, K + 1))), "maps"),
        (lambda: tfce_enhancer(ADJ, step=0.1)(bad[None]), "maps"),
        (lambda: tfce_step(bad), "maps"),
    ]
    for call, name in cases:
        with pytest.raises(ValueError, match=name):
            call()
