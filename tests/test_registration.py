"""Registration (the logarithm): recovery of exact shots, the alpha trade-off, convergence."""

import importlib.util
import pathlib
import warnings

import numpy as np
import pytest

from manifolds.errors import ConvergenceWarning
from manifolds.lddmm import LDDMMLandmarks, RegistrationSettings, register
from manifolds.lddmm.kernels import GaussianKernel


def exact_pair(space, seed, scale=0.25):
    rng = np.random.default_rng(seed)
    template = space.random_point(rng)
    momenta = space.random_tangent(template, rng, scale)
    return template, space.exp(template, momenta), momenta


@pytest.mark.parametrize("policy", ["dense", "grid"])
def test_exact_shot_is_recovered_with_small_alpha(policy):
    space = LDDMMLandmarks(
        30, 2, sigma=0.5, alpha=1e-3, control_points=policy, kernel_backend="numpy"
    )
    template, target, _ = exact_pair(space, seed=0)
    res = space.register(template, target)
    diameter = np.max(np.linalg.norm(target[:, None] - target[None], axis=-1))
    assert res.converged
    assert np.max(np.linalg.norm(res.deformed - target, axis=1)) <= 1e-3 * diameter
    np.testing.assert_allclose(res.residual, target - res.deformed, atol=0)
    np.testing.assert_allclose(
        res.objective, res.registration_error**2 + 1e-6 * res.rkhs_norm**2, rtol=1e-10
    )
    np.testing.assert_allclose(res.rms_error, res.registration_error / np.sqrt(30), rtol=1e-12)
    assert np.all(np.diff(res.history) <= 1e-12 * res.history[0])


def test_error_grows_and_norm_falls_with_alpha():
    rng = np.random.default_rng(1)
    base = LDDMMLandmarks(25, 3, sigma=0.6, alpha=0.0, control_points="dense")
    template, other = base.random_point(rng), base.random_point(rng)
    errors, norms = [], []
    for alpha in (0.03, 0.3, 3.0):
        space = LDDMMLandmarks(25, 3, sigma=0.6, alpha=alpha, control_points="dense")
        res = space.register(template, other)
        assert res.converged
        errors.append(res.registration_error)
        norms.append(res.rkhs_norm)
    assert errors[0] < errors[1] < errors[2]
    assert norms[0] > norms[1] > norms[2]
    # alpha -> infinity tends to the point distribution model: no deformation.
    assert errors[2] > 0.5 * np.linalg.norm(other - template)


def test_non_convergence_warns_and_warm_start_resumes():
    space = LDDMMLandmarks(20, 2, sigma=0.5, alpha=0.05, control_points="dense")
    template, target, _ = exact_pair(space, seed=2, scale=0.4)
    settings = space.settings
    with pytest.warns(ConvergenceWarning, match="did not converge"):
        early = register(template, target, 0.05, settings.replace(max_iter=2))
    assert not early.converged and early.n_iter == 2
    full = register(template, target, 0.05, settings)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        warm = register(template, target, 0.05, settings, initial_momenta=full.momenta)
    assert warm.converged
    np.testing.assert_allclose(warm.history[0], full.objective, rtol=1e-12)
    assert warm.objective <= full.objective * (1 + 1e-12)


@pytest.mark.parametrize("stopping", ["shape", "objective"])
def test_a_shape_registered_to_itself_converges_without_a_warning(stopping):
    """A zero gradient at the start is a minimum, not a failure to converge."""
    space = LDDMMLandmarks(15, 3, sigma=0.6, alpha=0.1, control_points="dense", stopping=stopping)
    shape = space.random_point(np.random.default_rng(3))
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        res = space.register(shape, shape)
    assert res.converged and res.registration_error == 0.0
    assert np.all(np.asarray(res.momenta) == 0.0)


def test_inverse_consistency_is_small_for_a_nearby_pair():
    space = LDDMMLandmarks(20, 2, sigma=0.5, alpha=0.01, control_points="dense")
    template, target, _ = exact_pair(space, seed=3, scale=0.2)
    err = space.inverse_consistency(template, target)
    gap = np.linalg.norm(target - template)
    assert 0 <= err < 0.05 * gap
    loose = LDDMMLandmarks(20, 2, sigma=0.5, alpha=1.0, control_points="dense")
    assert loose.inverse_consistency(template, target) > err


def test_compiled_and_numpy_registrations_agree():
    template, target, _ = exact_pair(
        LDDMMLandmarks(30, 3, sigma=0.5, alpha=0.05, kernel_backend="numpy"), seed=4
    )
    results = [
        register(template, target, 0.05, RegistrationSettings(sigma=0.5, kernel_backend=b))
        for b in ("numpy", "numba")
    ]
    np.testing.assert_allclose(results[0].objective, results[1].objective, rtol=1e-6)


def test_example_runs(tmp_path):
    path = pathlib.Path(__file__).resolve().parents[1] / "examples" / "register_meshes.py"
    spec = importlib.util.spec_from_file_location("register_meshes", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = tmp_path / "deformation.png"
    result = module.main(["--output", str(out), "--subdivisions", "1"])
    assert out.exists() and out.stat().st_size > 1000
    assert result.converged


def bent_ellipsoid(subdivisions=2):
    """The benchmark's ellipsoid and its bent and twisted copy (162 vertices by default)."""
    from ladders.study.cohort.benchmark_shapes import bent_ellipsoid as shapes

    template, target, _ = shapes(subdivisions)
    return template, target


def test_longer_lbfgs_memory_lowers_the_objective_within_a_fixed_budget():
    template, target = bent_ellipsoid()
    settings = RegistrationSettings(sigma=0.5, kernel_backend="numpy", max_iter=60)
    values = [
        register(template, target, 0.02, settings.replace(max_corrections=m), warn=False).objective
        for m in (10, 30, settings.max_corrections)
    ]
    assert values[2] < values[1] < values[0]


def test_compiled_triangular_solve_matches_scipy():
    import scipy.linalg

    from manifolds.lddmm.kernels_numba import solve_lower

    rng = np.random.default_rng(5)
    a = rng.standard_normal((40, 40))
    chol = np.linalg.cholesky(a @ a.T + 40 * np.eye(40))
    rhs = rng.standard_normal((40, 3))
    for transpose, trans in ((False, "N"), (True, "T")):
        ref = scipy.linalg.solve_triangular(chol, rhs, lower=True, trans=trans)
        np.testing.assert_allclose(solve_lower(chol, rhs, transpose), ref, rtol=1e-12, atol=0)
    with pytest.raises(ValueError, match="shapes"):
        solve_lower(chol, rhs[:5])


def test_parallel_kernel_path_matches_numpy_and_registration_is_thread_independent(
    monkeypatch,
):
    import numba

    from manifolds.lddmm import kernels_numba

    rng = np.random.default_rng(6)
    x, c = rng.standard_normal((70, 3)), rng.standard_normal((50, 3))
    mom, cot = rng.standard_normal((50, 3)), rng.standard_normal((70, 3))
    ref, fast = GaussianKernel(0.8, backend="numpy"), GaussianKernel(0.8, backend="numba")
    monkeypatch.setattr(kernels_numba, "PARALLEL_MIN_PAIRS", 1)
    pairs = [
        (fast.convolve(x, c, mom), ref.convolve(x, c, mom)),
        *zip(fast.hamiltonian_rhs(c, mom), ref.hamiltonian_rhs(c, mom)),
        *zip(fast.convolve_vjp(x, c, mom, cot), ref.convolve_vjp(x, c, mom, cot)),
        *zip(
            fast.hamiltonian_vjp(c, mom, cot[:50], x[:50]),
            ref.hamiltonian_vjp(c, mom, cot[:50], x[:50]),
        ),
    ]
    for a, b in pairs:
        np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-11 * np.abs(b).max())
    template, target = bent_ellipsoid(subdivisions=1)
    outcomes = []
    previous = numba.get_num_threads()
    try:
        for n_threads in sorted({1, numba.config.NUMBA_NUM_THREADS}):
            numba.set_num_threads(n_threads)
            res = register(
                template,
                target,
                0.02,
                RegistrationSettings(sigma=0.8, max_iter=20),
                kernel=fast,
                warn=False,
            )
            outcomes.append(res.momenta)
    finally:
        numba.set_num_threads(previous)
    for momenta in outcomes[1:]:
        np.testing.assert_array_equal(momenta, outcomes[0])


def test_blas_thread_limit_is_applied_and_restored():
    import threadpoolctl

    from manifolds.numerics.solvers import limit_blas_threads

    def blas_threads():
        return [
            p["num_threads"] for p in threadpoolctl.threadpool_info() if p["user_api"] == "blas"
        ]

    before = blas_threads()
    if not before:
        pytest.skip("no BLAS library with a thread pool loaded")
    with limit_blas_threads(1):
        assert all(n == 1 for n in blas_threads())
    assert blas_threads() == before
    with limit_blas_threads(None):
        assert blas_threads() == before


def test_a_lone_registration_equals_the_same_registration_in_a_batch_worker():
    """The set-up and the iterations run on the solver's BLAS threads whatever the caller's."""
    import threadpoolctl

    from ladders.study.cohort.benchmark_shapes import bent_ellipsoid
    from manifolds.kernels import kernel_threads
    from manifolds.numerics.solvers import limit_blas_threads

    template, target, _ = bent_ellipsoid(3, twist=0.4, bend=0.2)
    settings = RegistrationSettings(sigma=0.5, integrator="euler", max_iter=15)
    args = (template, target, 0.02, settings)
    with threadpoolctl.threadpool_limits(limits=4, user_api="blas"):
        lone = register(*args, control_points=template, warn=False)
    with kernel_threads(1), limit_blas_threads(1):  # what ladders.study.batch gives a worker
        worker = register(*args, control_points=template, warn=False)
    np.testing.assert_array_equal(lone.momenta, worker.momenta)
    assert lone.objective == worker.objective


def test_the_data_term_is_evaluated_once_per_forward_pass():
    """A surface data term costs as much as the flow: each iterate evaluates it once."""
    from manifolds.data_terms import VarifoldDistance

    class Counted(VarifoldDistance):
        calls = 0

        def value_and_gradient(self, points):
            Counted.calls += 1
            return super().value_and_gradient(points)

    rng = np.random.default_rng(5)
    t = np.linspace(0, 2 * np.pi, 9, endpoint=False)
    ring = np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], axis=1)
    vertices = np.vstack([ring, ring + [0, 0, 1], [[0, 0, -0.5], [0, 0, 1.5]]])
    faces = [[i, (i + 1) % 9, 9 + i] for i in range(9)]
    faces += [[(i + 1) % 9, 9 + (i + 1) % 9, 9 + i] for i in range(9)]
    faces += [[18, (i + 1) % 9, i] for i in range(9)] + [
        [19, 9 + i, 9 + (i + 1) % 9] for i in range(9)
    ]
    faces = np.array(faces)
    target = vertices * [1.2, 0.9, 1.1] + 0.05 * rng.standard_normal(vertices.shape)
    term = Counted(target, faces, faces, 0.5)
    Counted.calls = 0
    settings = RegistrationSettings(sigma=0.8, control_points="dense", max_iter=40)
    res = register(vertices, term, 0.1, settings, warn=False)
    assert res.n_iter >= 5
    # one call per forward pass (the adjoint passes add as many flow evaluations), and one
    # for the result's summary; evaluated twice per pass, it was 69 for 34 passes here
    assert Counted.calls <= res.n_flow_evaluations // 2 + 1
    assert res.history[-1] < 0.5 * res.history[0]
