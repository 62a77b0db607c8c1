"""The data-term seam of registrations (the squared distance of shapes in correspondence)."""

import numpy as np
import pytest

from manifolds.data_terms import DataTerm, SquaredDistance
from manifolds.lddmm import RegistrationSettings, register
from manifolds.lddmm.registration import registration_objective


def test_squared_distance_value_gradient_and_residual():
    rng = np.random.default_rng(0)
    target, x = rng.standard_normal((7, 3)), rng.standard_normal((7, 3))
    term = SquaredDistance(target)
    value, grad = term.value_and_gradient(x)
    np.testing.assert_allclose(value, ((target - x) ** 2).sum(), rtol=1e-14)
    np.testing.assert_allclose(term.residual(x), target - x)
    eps, d = 1e-6, rng.standard_normal(x.shape)
    fd = (term.value(x + eps * d) - term.value(x - eps * d)) / (2 * eps)
    assert abs(fd - (grad * d).sum()) <= 1e-7 * abs(fd)
    np.testing.assert_allclose(term.distance(x), np.linalg.norm(target - x), rtol=1e-14)
    with pytest.raises(ValueError, match="SquaredDistance"):
        term.value(x[:5])


class ShiftedDistance(DataTerm):
    """A user's data term: distance to the target shifted by a fixed vector (not least squares)."""

    def __init__(self, target, shift):
        self.target, self.shift = target, shift

    def value_and_gradient(self, points):
        r = points - self.target - self.shift
        return float((r * r).sum()), 2.0 * r


def test_a_custom_data_term_plugs_into_the_registration():
    rng = np.random.default_rng(1)
    template = rng.uniform(-1, 1, (15, 2))
    target = template + 0.1 * np.sin(template[:, ::-1])
    settings = RegistrationSettings(sigma=0.8, control_points="dense", max_iter=300)
    plain = register(template, target, 0.05, settings)
    shift = np.array([0.05, -0.02])
    custom = register(template, ShiftedDistance(target, shift), 0.05, settings, warn=False)
    # the custom term is the plain one towards the shifted target (from another start:
    # zero momenta, the custom term having no linearised minimiser)
    ref = register(template, target + shift, 0.05, settings)
    np.testing.assert_allclose(custom.objective, ref.objective, rtol=1e-4)
    np.testing.assert_allclose(custom.deformed, ref.deformed, atol=1e-3)
    assert custom.residual is None and custom.rms_error is None
    assert plain.residual is not None
    value, _, _, _ = registration_objective(
        settings.make_kernel(), template, ShiftedDistance(target, shift), template,
        ref.momenta, 0.05, "euler", 10,
    )  # fmt: skip
    np.testing.assert_allclose(value, ref.objective, rtol=1e-10)
