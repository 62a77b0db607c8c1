"""Bad input given to the generic algorithms of :mod:`ladders`.

Every case asserts the exception type and that the message names the argument.
"""

import numpy as np
import pytest

from ladders import (
    NoMomentumFlowError,
    centrality_error,
    fanning_scheme,
    involutivity_error,
    ladder_convergence,
    loglog_slope,
    pole_ladder,
    schild_ladder,
    symmetry_errors,
)
from manifolds import Euclidean, GaussianKernel, Hypersphere, LDDMMLandmarks, ManifoldError

NAN = np.nan


def e(i, n=3):
    out = np.zeros(n)
    out[i] = 1.0
    return out


def nan_like(x):
    out = np.array(x, dtype=float, copy=True)
    out.flat[0] = NAN
    return out


E3, S2 = Euclidean(3), Hypersphere(2)
X, Y, U = np.zeros(3), np.ones(3), np.array([0.0, 1.0, 0.0])
CP = np.zeros((3, 2))
FLOW = LDDMMLandmarks(3, 2, sigma=1.0, alpha=0.0, kernel_backend="numpy")  # a flow of momenta
KER = GaussianKernel(1.0, backend="numpy")  # a kernel alone is not a space


def ladder_cases():
    rows = [
        ("pole-n_rungs-nan", lambda: pole_ladder(E3, X, Y, U, n_rungs=NAN), ValueError, "n_rungs"),
        (
            "pole-n_rungs-inf",
            lambda: pole_ladder(E3, X, Y, U, n_rungs=np.inf),
            ValueError,
            "n_rungs",
        ),
        ("pole-n_rungs-zero", lambda: pole_ladder(E3, X, Y, U, n_rungs=0), ValueError, "n_rungs"),
        (
            "pole-n_rungs-float",
            lambda: pole_ladder(E3, X, Y, U, n_rungs=2.5),
            ValueError,
            "n_rungs",
        ),
        (
            "pole-n_rungs-string",
            lambda: pole_ladder(E3, X, Y, U, n_rungs="3"),
            ValueError,
            "n_rungs",
        ),
        (
            "pole-n_rungs-bool",
            lambda: pole_ladder(E3, X, Y, U, n_rungs=True),
            ValueError,
            "n_rungs",
        ),
        (
            "pole-exponent-nan",
            lambda: pole_ladder(E3, X, Y, U, scaling_exponent=NAN),
            ValueError,
            "scaling_exponent",
        ),
        (
            "pole-exponent-negative",
            lambda: pole_ladder(E3, X, Y, U, scaling_exponent=-1),
            ValueError,
            "scaling_exponent",
        ),
        (
            "pole-exponent-string",
            lambda: pole_ladder(E3, X, Y, U, scaling_exponent="a"),
            ValueError,
            "scaling_exponent",
        ),
        ("pole-space", lambda: pole_ladder("sphere", X, Y, U), TypeError, "space"),
        ("pole-base-nan", lambda: pole_ladder(E3, nan_like(X), Y, U), ManifoldError, "base"),
        ("pole-end-shape", lambda: pole_ladder(E3, X, np.ones(4), U), ManifoldError, "end"),
        ("pole-end-off-sphere", lambda: pole_ladder(S2, e(0), np.ones(3), U), ManifoldError, "end"),
        ("pole-tangent-nan", lambda: pole_ladder(E3, X, Y, nan_like(U)), ManifoldError, "tangent"),
        (
            "schild-n_rungs-nan",
            lambda: schild_ladder(E3, X, Y, U, n_rungs=NAN),
            ValueError,
            "n_rungs",
        ),
        (
            "schild-n_rungs-inf",
            lambda: schild_ladder(E3, X, Y, U, n_rungs=np.inf),
            ValueError,
            "n_rungs",
        ),
        ("errors-nan", lambda: symmetry_errors(E3, X, [NAN, 0, 0], Y), ManifoldError, "shape"),
        ("errors-template-shape", lambda: symmetry_errors(E3, 0, X, Y), ManifoldError, "template"),
        ("errors-other-complex", lambda: symmetry_errors(E3, X, Y, Y + 1j), ManifoldError, "other"),
        ("errors-space", lambda: symmetry_errors(None, X, Y, Y), TypeError, "space"),
        (
            "errors-distance",
            lambda: symmetry_errors(E3, X, Y, Y, distance=3),
            TypeError,
            "distance",
        ),
        ("centrality-nan", lambda: centrality_error(E3, nan_like(X), Y), ManifoldError, "template"),
        (
            "involutivity-center",
            lambda: involutivity_error(S2, np.ones(3), e(0)),
            ManifoldError,
            "center",
        ),
        (
            "fanning-n_steps-nan",
            lambda: fanning_scheme(FLOW, CP, CP, CP, n_steps=NAN),
            ValueError,
            "n_steps",
        ),
        (
            "fanning-n_steps-zero",
            lambda: fanning_scheme(FLOW, CP, CP, CP, n_steps=0),
            ValueError,
            "n_steps",
        ),
        (
            "fanning-epsilon",
            lambda: fanning_scheme(FLOW, CP, CP, CP, epsilon=-1.0),
            ValueError,
            "epsilon",
        ),
        (
            "fanning-drift",
            lambda: fanning_scheme(FLOW, CP, CP, CP, max_norm_drift=0.0),
            ValueError,
            "max_norm_drift",
        ),
        (
            "fanning-tangent-shape",
            lambda: fanning_scheme(FLOW, CP, CP, np.zeros((4, 2))),
            ValueError,
            "tangent",
        ),
        (
            "fanning-momenta-nan",
            lambda: fanning_scheme(FLOW, CP, np.full((3, 2), NAN), CP),
            ValueError,
            "geodesic_momenta",
        ),
        (
            "fanning-control-points",
            lambda: fanning_scheme(FLOW, np.zeros(3), CP, CP),
            ValueError,
            "control_points",
        ),
        (
            "fanning-kernel-not-a-space",
            lambda: fanning_scheme(KER, CP, CP, CP),
            NoMomentumFlowError,
            "fanning_scheme: space: expected a space with a flow of momenta",
        ),
        (
            "convergence-empty",
            lambda: ladder_convergence(E3, pole_ladder, X, Y, U, U, n_rungs=[]),
            ValueError,
            "n_rungs",
        ),
        (
            "convergence-zero",
            lambda: ladder_convergence(E3, pole_ladder, X, Y, U, U, n_rungs=[2, 0]),
            ValueError,
            "n_rungs",
        ),
        (
            "convergence-ladder",
            lambda: ladder_convergence(E3, "pole", X, Y, U, U),
            TypeError,
            "ladder",
        ),
        ("slope-short", lambda: loglog_slope([1.0], [1.0]), ValueError, "x, y"),
        ("slope-negative", lambda: loglog_slope([1.0, 2.0], [1.0, -1.0]), ValueError, "x, y"),
    ]
    return [pytest.param(f, exc, m, id=n) for n, f, exc, m in rows]


LADDER_CASES = ladder_cases()


@pytest.mark.parametrize(("call", "exc", "name"), LADDER_CASES)
def test_ladders_bad_input_raises_named_error(call, exc, name):
    with pytest.raises(exc) as info:
        call()
    assert name in str(info.value), str(info.value)
