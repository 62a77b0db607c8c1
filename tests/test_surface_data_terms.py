"""Current and varifold data terms: exact gradients, backends, invariances, memory, registration."""

import tracemalloc

import autograd.numpy as anp
import numpy as np
import pytest
import trimesh
from autograd import grad

from ladders.study import bent_ellipsoid
from manifolds import ManifoldError
from manifolds.data_terms import (
    CurrentDistance,
    DataTerm,
    VarifoldDistance,
    triangle_geometry,
    triangle_geometry_vjp,
)
from manifolds.data_terms.surface_distance import surface_features
from manifolds.data_terms.surface_kernels import pair_sum
from manifolds.lddmm import LDDMMLandmarks, RegistrationSettings, SVFLandmarks, register

TERMS = {"current": CurrentDistance, "varifold": VarifoldDistance}


def sphere(subdivisions, radius=1.0):
    m = trimesh.creation.icosphere(subdivisions)
    return radius * np.array(m.vertices), np.array(m.faces)


def remeshed(vertices, faces, n_faces):
    """The same surface with another triangulation (subdivided, then decimated)."""
    m = trimesh.Trimesh(vertices, faces, process=False).subdivide().subdivide()
    r = m.simplify_quadric_decimation(face_count=n_faces)
    faces = np.array(r.faces)[r.nondegenerate_faces(height=1e-12)]
    return np.array(r.vertices), faces


def random_rotation(rng):
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q *= np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def autograd_distance(kind, sigma, faces, target_v, target_f):
    """An independent implementation: ``x -> ||A(x) - B||^2`` written with autograd.numpy."""

    def feats(v, f):
        a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
        return (a + b + c) / 3.0, 0.5 * anp.cross(b - a, c - a)

    def inner(cx, nx, cy, ny):
        d2 = anp.sum((cx[:, None, :] - cy[None, :, :]) ** 2, axis=2)
        k = anp.exp(-d2 / sigma**2)
        dots = anp.dot(nx, ny.T)
        if kind == "current":
            return anp.sum(k * dots)
        ax = anp.sqrt(anp.sum(nx * nx, axis=1))
        ay = anp.sqrt(anp.sum(ny * ny, axis=1))
        return anp.sum(k * dots**2 / (ax[:, None] * ay[None, :]))

    cb, nb = feats(target_v, target_f)

    def dist(x):
        ca, na = feats(x, faces)
        return inner(ca, na, ca, na) - 2.0 * inner(ca, na, cb, nb) + inner(cb, nb, cb, nb)

    return dist


@pytest.fixture(scope="module")
def meshes():
    rng = np.random.default_rng(0)
    v, f = sphere(2)
    x = v + 0.05 * rng.standard_normal(v.shape)  # the deformed template
    tv, tf = remeshed(v * [1.1, 0.9, 1.0], f, 300)  # a target with another triangulation
    return x, f, tv, tf


@pytest.mark.parametrize("kind", TERMS)
@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_gradient_matches_autograd_and_central_differences(kind, backend, meshes):
    x, f, tv, tf = meshes
    sigma = 0.4
    term = TERMS[kind](tv, tf, f, sigma, backend=backend, block_size=5000)
    value, g = term.value_and_gradient(x)
    ref = autograd_distance(kind, sigma, f, tv, tf)
    np.testing.assert_allclose(value, ref(x), rtol=1e-11)
    g_ag = grad(ref)(x)
    assert np.abs(g - g_ag).max() <= 1e-9 * np.abs(g_ag).max()
    rng = np.random.default_rng(1)
    for _ in range(3):
        d = rng.standard_normal(x.shape)
        eps = 1e-5
        fd = (term.value(x + eps * d) - term.value(x - eps * d)) / (2 * eps)
        assert abs(fd - (g * d).sum()) <= 1e-7 * abs(fd)


def test_geometry_vjp_is_the_transpose_of_the_geometry_differential(meshes):
    x, f, _, _ = meshes
    rng = np.random.default_rng(2)
    g_c, g_n = rng.standard_normal((2, len(f), 3))
    d = rng.standard_normal(x.shape)
    eps = 1e-6
    (cp, np_), (cm, nm) = triangle_geometry(x + eps * d, f), triangle_geometry(x - eps * d, f)
    fd = ((cp - cm) * g_c + (np_ - nm) * g_n).sum() / (2 * eps)
    np.testing.assert_allclose((triangle_geometry_vjp(x, f, g_c, g_n) * d).sum(), fd, rtol=1e-8)


@pytest.mark.parametrize("kind", TERMS)
def test_compiled_sums_match_the_numpy_reference(kind, meshes):
    x, f, tv, tf = meshes
    fx, fy = surface_features(x, f), surface_features(tv, tf)
    ref = pair_sum(kind, fx, fy, 1 / 0.3**2, "numpy", block_size=777)
    out = pair_sum(kind, fx, fy, 1 / 0.3**2, "numba")
    np.testing.assert_allclose(out[0], ref[0], rtol=1e-12)
    for a, b in zip(out[1:], ref[1:]):
        assert np.abs(a - b).max() <= 1e-10 * np.abs(b).max()
    whole = pair_sum(kind, fx, fy, 1 / 0.3**2, "numpy", block_size=10**9)
    np.testing.assert_allclose(whole[0], ref[0], rtol=1e-13)


@pytest.mark.parametrize("kind", TERMS)
def test_zero_at_identity_symmetric_and_rigid_invariant(kind, meshes):
    x, f, tv, tf = meshes
    term = TERMS[kind](tv, tf, f, 0.5)
    assert abs(TERMS[kind](x, f, f, 0.5).value(x)) <= 1e-12 * term.norm_sq(x, f)
    forward = term.value(x)
    backward = TERMS[kind](x, f, tf, 0.5).value(tv)
    np.testing.assert_allclose(forward, backward, rtol=1e-10)
    rng = np.random.default_rng(3)
    rot, shift = random_rotation(rng), rng.standard_normal(3)
    moved = TERMS[kind](tv @ rot.T + shift, tf, f, 0.5).value(x @ rot.T + shift)
    np.testing.assert_allclose(moved, forward, rtol=1e-10)
    assert forward > 1e-3 * term.target_norm_sq  # the meshes do differ


def test_orientation_matters_to_the_current_only(meshes):
    x, f, tv, tf = meshes
    flipped = tf[:, ::-1]
    var, var_flip = VarifoldDistance(tv, tf, f, 0.5), VarifoldDistance(tv, flipped, f, 0.5)
    np.testing.assert_allclose(var_flip.value(x), var.value(x), rtol=1e-12)
    cur, cur_flip = CurrentDistance(tv, tf, f, 0.5), CurrentDistance(tv, flipped, f, 0.5)
    # ||A + B||^2 = ||A - B||^2 + 4 <A, B>
    inner = (cur.norm_sq(x, f) + cur.target_norm_sq - cur.value(x)) / 2
    np.testing.assert_allclose(cur_flip.value(x), cur.value(x) + 4 * inner, rtol=1e-10)
    assert cur_flip.value(x) > 10 * cur.value(x)


@pytest.mark.parametrize("kind", TERMS)
@pytest.mark.parametrize("backend", ["numpy", "numba"])
def test_zero_area_faces_add_nothing_and_give_no_nan(kind, backend, meshes):
    x, f, tv, tf = meshes
    degenerate = np.vstack([f, [[0, 0, 1], [2, 3, 3]]])  # two triangles of zero area
    plain = TERMS[kind](tv, tf, f, 0.5, backend=backend)
    with_zero = TERMS[kind](tv, tf, degenerate, 0.5, backend=backend)
    v0, g0 = plain.value_and_gradient(x)
    v1, g1 = with_zero.value_and_gradient(x)
    assert np.isfinite(g1).all()
    np.testing.assert_allclose(v1, v0, rtol=1e-12)
    np.testing.assert_allclose(g1, g0, atol=1e-12 * np.abs(g0).max())


def test_block_size_bounds_the_numpy_temporaries():
    v, f = sphere(4, radius=30.0)  # 5,120 faces: a full 5120 x 5120 matrix is 210 MB
    block = 2**16
    term = VarifoldDistance(v, f, f, 5.0, backend="numpy", block_size=block)
    x = v * 1.01
    tracemalloc.start()
    term.value_and_gradient(x)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    per_face = 8 * 3 * len(f)  # one (f, 3) float64 array
    assert peak < 8 * block * 8 + 40 * per_face  # a few blocks and O(f) arrays: < 10 MB
    assert peak < 0.05 * len(f) ** 2 * 8


def test_landmark_weight_scales_like_the_squared_distance_of_landmarks():
    v, f = sphere(2, radius=1.0)
    term = VarifoldDistance(v, f, f, 0.3, weight="landmarks")
    big = VarifoldDistance(10 * v, f, f, 3.0, weight="landmarks")
    # a varifold norm^2 scales as length^4, the landmarks' k |t|^2 as length^2
    np.testing.assert_allclose(big.weight, term.weight / 100, rtol=1e-9)
    t = np.array([0.0, 0.0, 0.003])
    np.testing.assert_allclose(term.value(v + t), len(v) * t @ t, rtol=0.2)


def test_key_identifies_the_term(meshes):
    _, f, tv, tf = meshes
    a, b = VarifoldDistance(tv, tf, f, 0.5), VarifoldDistance(tv.copy(), tf, f, 0.5)
    assert a.key() == b.key()
    assert a.key() != VarifoldDistance(tv, tf, f, 0.4).key()
    assert a.key() != CurrentDistance(tv, tf, f, 0.5).key()
    assert a.key() != VarifoldDistance(tv, tf, f, 0.5, weight=2.0).key()


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(target_faces=np.array([[0, 1, 999]])), "target faces.*out of range|must be in"),
        (dict(template_faces=np.array([[0, 1, -1]])), "template_faces.*must be"),
        (dict(template_faces=np.zeros((4, 2), int)), r"template_faces.*shape \(f, 3\)"),
        (dict(target_vertices=np.full((5, 3), np.nan)), "target vertices.*NaN"),
        (dict(sigma_w=-1.0), "sigma_w"),
        (dict(weight="auto"), "weight"),
        (dict(backend="gpu"), "backend"),
    ],
)
def test_bad_input_names_the_argument(change, match, meshes):
    _, f, tv, tf = meshes
    args = dict(target_vertices=tv, target_faces=tf, template_faces=f, sigma_w=0.5)
    args.update(change)
    with pytest.raises(ValueError, match=match):
        VarifoldDistance(**args)


def test_bad_points_are_refused(meshes):
    x, f, tv, tf = meshes
    term = VarifoldDistance(tv, tf, f, 0.5)
    with pytest.raises(ValueError, match=r"VarifoldDistance.*shape"):
        term.value(x[:-1])
    bad = x.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ManifoldError, match="NaN"):
        term.value_and_gradient(bad)


@pytest.fixture(scope="module")
def ellipsoid_pair():
    template, target, faces = bent_ellipsoid(subdivisions=2)  # 162 vertices, bent copy
    tv, tf = remeshed(target, faces, 400)
    return template, target, faces, tv, tf


def rms(a, b):
    return float(np.sqrt(((a - b) ** 2).sum(1).mean()))


def test_registration_onto_a_remeshed_target(ellipsoid_pair):
    template, target, faces, tv, tf = ellipsoid_pair
    term = VarifoldDistance(tv, tf, faces, 0.15, weight="landmarks")
    assert isinstance(term, DataTerm) and not term.least_squares and not term.corresponds
    settings = RegistrationSettings(sigma=0.5, control_points="grid", max_iter=400)
    res = register(template, term, 0.1, settings)
    assert res.residual is None and res.rms_error is None
    # the template lands on the target surface (its tangential sliding is free up to the
    # regulariser), and closer to the true bent copy it was made from
    surface = trimesh.Trimesh(tv, tf, process=False)
    before = trimesh.proximity.closest_point(surface, template)[1]
    after = trimesh.proximity.closest_point(surface, res.deformed)[1]
    assert after.mean() < 0.2 * before.mean()
    assert rms(res.deformed, target) < 0.5 * rms(template, target)
    assert res.registration_error < 0.6 * term.distance(template)
    assert res.history[-1] < res.history[0]


def test_landmark_space_log_and_register_accept_a_data_term(ellipsoid_pair):
    template, target, faces, tv, tf = ellipsoid_pair
    space = LDDMMLandmarks(len(template), 3, sigma=0.5, alpha=0.1, control_points="grid")
    term = VarifoldDistance(tv, tf, faces, 0.15, weight="landmarks")
    mu = space.log(template, term)
    assert space.n_registrations == 1
    res = space.register(template, VarifoldDistance(tv, tf, faces, 0.15, weight="landmarks"))
    assert space.n_registrations == 1  # same key: cached
    np.testing.assert_allclose(mu, res.momenta)
    np.testing.assert_allclose(space.exp(template, mu), res.deformed, atol=1e-12)
    with pytest.raises(ManifoldError, match="correspondence"):
        space.log_with_residual(template, term)
    small = VarifoldDistance(tv, tf, faces[:10], 0.15)  # reads fewer points than the space has
    with pytest.raises(ManifoldError, match="template points"):
        space.log(template, small)


def test_svf_space_registers_onto_a_data_term(ellipsoid_pair):
    template, _, faces, tv, tf = ellipsoid_pair
    space = SVFLandmarks(len(template), 3, sigma=0.5, alpha=0.1, control_points="grid")
    res = space.register(template, VarifoldDistance(tv, tf, faces, 0.15, weight="landmarks"))
    surface = trimesh.Trimesh(tv, tf, process=False)
    before = trimesh.proximity.closest_point(surface, template)[1]
    after = trimesh.proximity.closest_point(surface, res.deformed)[1]
    assert after.mean() < 0.2 * before.mean()
