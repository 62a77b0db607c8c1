"""Bad input given to the spaces of :mod:`manifolds` (the ladders and the CLI: sibling files).

Every case asserts the exception type (or, on the command line, exit status 2,
one line on standard error and no traceback) and that the message names the
argument (or flag) at fault.
"""

import numpy as np
import pytest

from manifolds import (
    Euclidean,
    GaussianKernel,
    Hyperbolic,
    Hypersphere,
    LDDMMLandmarks,
    ManifoldError,
    PoincareHalfPlane,
    ResidualAugmented,
    SPDMatrices,
    WarpedSurface,
)
from manifolds.lddmm import RegistrationSettings
from manifolds.lddmm.shapes import random_shape

NAN = np.nan
RNG = np.random.default_rng(0)


def e(i, n=3):
    out = np.zeros(n)
    out[i] = 1.0
    return out


# name -> (space, point, tangent, huge tangent (overflows exp), a point off the manifold)
CLOSED = {
    "E3": (Euclidean(3), np.full(3, 1e308), np.ones(3), np.full(3, 1e308), None),
    "S2": (Hypersphere(2), e(0), 0.3 * e(1), 1e300 * e(1), np.ones(3)),
    "H2": (Hyperbolic(2), e(0), 0.3 * e(1), 1000.0 * e(1), 0.5 * e(0)),
    "SPD2": (SPDMatrices(2), np.eye(2), np.diag([0.1, -0.1]), np.diag([1e3, 0.0]), None),
}
CLOSED["SPD2"] = (*CLOSED["SPD2"][:4], np.array([[1.0, 2.0], [2.0, 1.0]]))


def nan_like(x):
    out = np.array(x, dtype=float, copy=True)
    out.flat[0] = NAN
    return out


def closed_form_cases():
    """About 30 cases per closed-form space."""
    cases = []
    for key, (sp, p, v, huge, off) in CLOSED.items():
        p0 = np.zeros(sp.point_shape) if key == "E3" else p
        wrong = np.zeros(tuple(s + 1 for s in sp.point_shape))
        batch2, batch3 = np.stack([p0, p0]), np.stack([v, v, v])
        cx = np.asarray(v, dtype=complex) * (1 + 1j)
        rows = [
            (
                "exp-nan",
                lambda sp=sp, p0=p0, v=v: sp.exp(p0, nan_like(v)),
                ManifoldError,
                "tangent",
            ),
            ("exp-complex", lambda sp=sp, p0=p0, cx=cx: sp.exp(p0, cx), ManifoldError, "tangent"),
            ("exp-string", lambda sp=sp, p0=p0: sp.exp(p0, "abc"), ManifoldError, "tangent"),
            ("exp-shape", lambda sp=sp, p0=p0, w=wrong: sp.exp(p0, w), ManifoldError, "tangent"),
            (
                "exp-inf",
                lambda sp=sp, p0=p0, v=v: sp.exp(p0, np.full(np.shape(v), np.inf)),
                ManifoldError,
                "tangent",
            ),
            ("exp-batch", lambda sp=sp, a=batch2, b=batch3: sp.exp(a, b), ManifoldError, "tangent"),
            ("exp-overflow", lambda sp=sp, p=p, h=huge: sp.exp(p, h), ManifoldError, "tangent"),
            (
                "exp-point-nan",
                lambda sp=sp, p0=p0, v=v: sp.exp(nan_like(p0), v),
                ManifoldError,
                "point",
            ),
            ("log-nan", lambda sp=sp, p0=p0: sp.log(p0, nan_like(p0)), ManifoldError, "other"),
            ("log-complex", lambda sp=sp, p0=p0: sp.log(p0, p0 + 0j), ManifoldError, "other"),
            ("log-shape", lambda sp=sp, p0=p0, w=wrong: sp.log(p0, w), ManifoldError, "other"),
            (
                "log-batch",
                lambda sp=sp, a=batch2, p0=p0: sp.log(a, np.stack([p0] * 3)),
                ManifoldError,
                "other",
            ),
            (
                "symmetry-nan",
                lambda sp=sp, p0=p0: sp.symmetry(nan_like(p0), p0),
                ManifoldError,
                "center",
            ),
            (
                "symmetry-complex",
                lambda sp=sp, p0=p0: sp.symmetry(p0, p0 + 0j),
                ManifoldError,
                "point",
            ),
            (
                "symmetry-batch",
                lambda sp=sp, a=batch2, p0=p0: sp.symmetry(a, np.stack([p0] * 3)),
                ManifoldError,
                "point",
            ),
            (
                "midpoint-shape",
                lambda sp=sp, p0=p0, w=wrong: sp.midpoint(p0, w),
                ManifoldError,
                "b",
            ),
            (
                "midpoint-nan",
                lambda sp=sp, p0=p0: sp.midpoint(nan_like(p0), p0),
                ManifoldError,
                "a",
            ),
            ("dist-nan", lambda sp=sp, p0=p0: sp.dist(p0, nan_like(p0)), ManifoldError, "b"),
            (
                "dist-batch",
                lambda sp=sp, a=batch2, p0=p0: sp.dist(a, np.stack([p0] * 3)),
                ManifoldError,
                "b",
            ),
            (
                "inner-nan",
                lambda sp=sp, p0=p0, v=v: sp.inner(p0, nan_like(v), v),
                ManifoldError,
                "u",
            ),
            (
                "inner-complex",
                lambda sp=sp, p0=p0, v=v, cx=cx: sp.inner(p0, v, cx),
                ManifoldError,
                "v",
            ),
            (
                "transport-nan",
                lambda sp=sp, p0=p0, v=v: sp.parallel_transport(p0, nan_like(p0), v),
                ManifoldError,
                "end",
            ),
            (
                "transport-tangent",
                lambda sp=sp, p0=p0, v=v: sp.parallel_transport(p0, p0, nan_like(v)),
                ManifoldError,
                "tangent",
            ),
            (
                "n_samples-float",
                lambda sp=sp: sp.random_point(RNG, 2.5),
                ManifoldError,
                "n_samples",
            ),
            (
                "n_samples-negative",
                lambda sp=sp: sp.random_point(RNG, -1),
                ManifoldError,
                "n_samples",
            ),
            ("n_samples-zero", lambda sp=sp: sp.random_point(RNG, 0), ManifoldError, "n_samples"),
            (
                "n_samples-string",
                lambda sp=sp: sp.random_point(RNG, "3"),
                ManifoldError,
                "n_samples",
            ),
            (
                "n_samples-bool",
                lambda sp=sp: sp.random_point(RNG, True),
                ManifoldError,
                "n_samples",
            ),
            ("rng-int", lambda sp=sp: sp.random_point(42), TypeError, "rng"),
            (
                "rng-legacy",
                lambda sp=sp: sp.random_point(np.random.RandomState(0)),
                TypeError,
                "rng",
            ),
            ("tangent-rng", lambda sp=sp, p0=p0: sp.random_tangent(p0, None), TypeError, "rng"),
            (
                "scale-negative",
                lambda sp=sp, p0=p0: sp.random_tangent(p0, RNG, -1.0),
                ManifoldError,
                "scale",
            ),
            (
                "scale-nan",
                lambda sp=sp, p0=p0: sp.random_tangent(p0, RNG, NAN),
                ManifoldError,
                "scale",
            ),
        ]
        if off is not None:
            rows.append(
                ("log-off-manifold", lambda sp=sp, p=p, o=off: sp.log(p, o), ManifoldError, "other")
            )
            rows.append(
                ("exp-off-manifold", lambda sp=sp, o=off, v=v: sp.exp(o, v), ManifoldError, "point")
            )
        cases += [pytest.param(f, exc, m, id=f"{key}-{n}") for n, f, exc, m in rows]
    return cases


PH, WS = PoincareHalfPlane(), WarpedSurface()
R = ResidualAugmented(Euclidean((3, 2)))
P2 = np.array([0.0, 1.0])


def ode_and_wrapper_cases():
    rows = []
    for key, sp in (("PH", PH), ("WS", WS)):
        rows += [
            (f"{key}-exp-nan", lambda sp=sp: sp.exp(P2, [NAN, 0.0]), ManifoldError, "tangent"),
            (f"{key}-exp-complex", lambda sp=sp: sp.exp(P2, [1j, 0.0]), ManifoldError, "tangent"),
            (
                f"{key}-exp-batch",
                lambda sp=sp: sp.exp(np.stack([P2, P2]), np.zeros((2, 2))),
                ManifoldError,
                "point",
            ),
            (f"{key}-log-shape", lambda sp=sp: sp.log(P2, np.zeros(3)), ManifoldError, "other"),
            (
                f"{key}-n_samples",
                lambda sp=sp: sp.random_point(RNG, -1),
                ManifoldError,
                "n_samples",
            ),
            (
                f"{key}-n_samples-float",
                lambda sp=sp: sp.random_point(RNG, 1.5),
                ManifoldError,
                "n_samples",
            ),
            (f"{key}-rng", lambda sp=sp: sp.random_point(0), TypeError, "rng"),
            (f"{key}-scale", lambda sp=sp: sp.random_tangent(P2, RNG, NAN), ManifoldError, "scale"),
        ]
    rows += [
        ("PH-log-outside", lambda: PH.log(P2, [0.0, -1.0]), ManifoldError, "other"),
        ("PH-exp-outside", lambda: PH.exp([0.0, -1.0], [0.0, 0.1]), ManifoldError, "point"),
        ("R-base", lambda: ResidualAugmented("euclidean"), TypeError, "base"),
        (
            "R-log-nan",
            lambda: R.log(np.zeros((3, 2)), np.full((3, 2), NAN)),
            ManifoldError,
            "other",
        ),
        ("R-n_samples", lambda: R.random_point(RNG, 0), ManifoldError, "n_samples"),
        ("R-rng", lambda: R.random_tangent(np.zeros((3, 2)), "seed"), TypeError, "rng"),
        (
            "R-exp-nan",
            lambda: R.exp(np.zeros((3, 2)), np.full((3, 2), NAN)),
            ManifoldError,
            "tangent",
        ),
    ]
    return [pytest.param(f, exc, m, id=n) for n, f, exc, m in rows]


def lddmm(**kw):
    params = dict(n_landmarks=4, dim=2, sigma=0.8, alpha=0.1, control_points="dense")
    params.update(kw)
    return LDDMMLandmarks(**params)


SHAPE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])


def lddmm_cases():
    sp = lddmm()
    rows = [
        ("random_shape-rng", lambda: random_shape(7, 4, 2), TypeError, "rng"),
        ("random_shape-k", lambda: random_shape(RNG, 0, 2), ManifoldError, "n_landmarks"),
        ("random_shape-dim", lambda: random_shape(RNG, 4, 4), ManifoldError, "dim"),
        ("sigma-string", lambda: lddmm(sigma="abc"), ManifoldError, "sigma"),
        ("sigma-zero", lambda: lddmm(sigma=0.0), ManifoldError, "sigma"),
        ("sigma-negative", lambda: lddmm(sigma=-1.0), ManifoldError, "sigma"),
        ("sigma-nan", lambda: lddmm(sigma=NAN), ManifoldError, "sigma"),
        ("sigma-none", lambda: lddmm(sigma=None), ManifoldError, "sigma"),
        ("alpha-negative", lambda: lddmm(alpha=-1.0), ManifoldError, "alpha"),
        ("alpha-string", lambda: lddmm(alpha="x"), ManifoldError, "alpha"),
        ("n_landmarks-zero", lambda: lddmm(n_landmarks=0), ManifoldError, "n_landmarks"),
        ("n_landmarks-float", lambda: lddmm(n_landmarks=2.5), ManifoldError, "n_landmarks"),
        ("n_landmarks-string", lambda: lddmm(n_landmarks="4"), ManifoldError, "n_landmarks"),
        ("dim-4", lambda: lddmm(dim=4), ManifoldError, "dim"),
        ("n_steps-zero", lambda: lddmm(n_steps=0), ManifoldError, "n_steps"),
        ("n_steps-nan", lambda: lddmm(n_steps=NAN), ManifoldError, "n_steps"),
        ("max_iter", lambda: lddmm(max_iter=-5), ManifoldError, "max_iter"),
        ("setting-unknown", lambda: lddmm(bogus=1), ManifoldError, "bogus"),
        ("settings-type", lambda: lddmm(settings="fast"), TypeError, "settings"),
        ("solver-unknown", lambda: lddmm(solver="newton-raphson"), ManifoldError, "solver"),
        ("stopping-unknown", lambda: lddmm(stopping="never"), ManifoldError, "stopping"),
        ("shape_tol-negative", lambda: lddmm(shape_tol=-1.0), ManifoldError, "shape_tol"),
        (
            "control_points-policy",
            lambda: lddmm(control_points="bogus"),
            ManifoldError,
            "control_points",
        ),
        (
            "control_points-shape",
            lambda: lddmm(control_points=np.zeros((3, 3))),
            ManifoldError,
            "control_points",
        ),
        ("integrator", lambda: lddmm(integrator="bogus"), ValueError, "integrator"),
        ("backend", lambda: lddmm(kernel_backend="gpu"), ManifoldError, "kernel_backend"),
        ("cache_size", lambda: lddmm(cache_size=-1), ManifoldError, "cache_size"),
        (
            "max_control_points",
            lambda: lddmm(max_control_points=0),
            ManifoldError,
            "max_control_points",
        ),
        (
            "grid-budget",
            lambda: lddmm(sigma=1e-3, control_points="grid").control_points(SHAPE),
            ManifoldError,
            "sigma",
        ),
        ("exp-overflow", lambda: sp.exp(SHAPE, np.full((4, 2), 1e200)), ManifoldError, "momenta"),
        ("exp-shape", lambda: sp.exp(SHAPE, np.zeros((3, 2))), ManifoldError, "tangent"),
        ("exp-complex", lambda: sp.exp(SHAPE, np.zeros((4, 2)) + 1j), ManifoldError, "tangent"),
        ("log-nan", lambda: sp.log(SHAPE, np.full((4, 2), NAN)), ManifoldError, "other"),
        ("log-shape", lambda: sp.log(SHAPE, np.zeros((5, 2))), ManifoldError, "other"),
        ("n_samples", lambda: sp.random_point(RNG, -1), ManifoldError, "n_samples"),
        ("rng", lambda: sp.random_point(None), TypeError, "rng"),
        ("scale", lambda: sp.random_tangent(SHAPE, RNG, -2.0), ManifoldError, "scale"),
        ("kernel-sigma", lambda: GaussianKernel("abc"), ManifoldError, "sigma"),
        (
            "kernel-block_size",
            lambda: GaussianKernel(1.0, block_size=0),
            ManifoldError,
            "block_size",
        ),
        ("settings-max_iter", lambda: SETTINGS.replace(max_iter=-5), ManifoldError, "max_iter"),
        ("settings-max_iter-zero", lambda: SETTINGS.replace(max_iter=0), ManifoldError, "max_iter"),
        (
            "settings-max_iter-float",
            lambda: SETTINGS.replace(max_iter=2.5),
            ManifoldError,
            "max_iter",
        ),
        ("settings-ftol", lambda: SETTINGS.replace(ftol=NAN), ManifoldError, "ftol"),
        ("settings-gtol", lambda: SETTINGS.replace(gtol=-1.0), ManifoldError, "gtol"),
        (
            "settings-max_corrections",
            lambda: SETTINGS.replace(max_corrections=0),
            ManifoldError,
            "max_corrections",
        ),
        (
            "settings-max_line_search",
            lambda: SETTINGS.replace(max_line_search=0),
            ManifoldError,
            "max_line_search",
        ),
        (
            "settings-blas_threads",
            lambda: SETTINGS.replace(blas_threads=0),
            ManifoldError,
            "blas_threads",
        ),
        (
            "settings-optimize_control_points",
            lambda: SETTINGS.replace(optimize_control_points="yes"),
            ManifoldError,
            "optimize_control_points",
        ),
        ("settings-sigma", lambda: RegistrationSettings(sigma=-2.0), ManifoldError, "sigma"),
        (
            "settings-from_dict",
            lambda: RegistrationSettings.from_dict({"sigma": 1.0, "sgima": 2.0}),
            ManifoldError,
            "sgima",
        ),
    ]
    return [pytest.param(f, exc, m, id=f"lddmm-{n}") for n, f, exc, m in rows]


SETTINGS = RegistrationSettings(sigma=1.0)
API_CASES = closed_form_cases() + ode_and_wrapper_cases() + lddmm_cases()


@pytest.mark.parametrize(("call", "exc", "name"), API_CASES)
def test_api_bad_input_raises_named_error(call, exc, name):
    with pytest.raises(exc) as info:
        call()
    assert name in str(info.value), str(info.value)


@pytest.mark.parametrize("value", ["a", 0, -1, 1.5, True, None])
@pytest.mark.parametrize("cls", ["Hypersphere", "Hyperbolic", "SPDMatrices"])
def test_dimension_errors_name_the_class_and_the_argument(cls, value):
    import manifolds

    with pytest.raises(ValueError, match=rf"^{cls}: n: expected an integer >= 1, got ") as info:
        getattr(manifolds, cls)(value)
    assert repr(value) in str(info.value)
