"""The data term of a registration: how far the deformed template is from the target.

A registration (paper, eq. 3) minimises ``D(phi_1(T)) + alpha^2 ||v_0||_H^2``.
The regulariser belongs to the deformation model; the data term ``D`` is a
function of the deformed template's points alone, and this is its interface:
its value and its gradient with respect to those points, which the model's
adjoint pulls back to the momenta (and control points). A least-squares term,
``D(x) = ||r(x)||^2`` with a residual vector ``r``, also exposes ``r``, which a
Gauss-Newton solver and the residual-augmented space (eq. 4) use.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

__all__ = ["DataTerm"]


class DataTerm(ABC):
    """``D(x)`` for the deformed template's points ``x`` of shape ``(k, d)``.

    Subclasses implement :meth:`value_and_gradient`; least-squares terms set
    :attr:`least_squares` and implement :meth:`residual`.

    Attributes
    ----------
    least_squares : bool
        ``D(x) = ||r(x)||^2`` with :meth:`residual` ``r``.
    corresponds : bool
        The target has one point per template point (in order): :meth:`residual`
        is then the displacement ``delta = S - x`` of eq. (4).
    """

    least_squares: bool = False
    corresponds: bool = False

    @abstractmethod
    def value_and_gradient(self, points: np.ndarray) -> tuple[float, np.ndarray]:
        """``(D(x), dD/dx)``, the gradient of shape ``(k, d)``."""

    def value(self, points: np.ndarray) -> float:
        """``D(x)``."""
        return self.value_and_gradient(points)[0]

    def residual(self, points: np.ndarray) -> np.ndarray:
        """The residual ``r(x)`` with ``D(x) = ||r(x)||^2`` (least-squares terms only)."""
        raise NotImplementedError(f"{type(self).__name__} is not a least-squares data term")

    def gauss_newton_product(self, points: np.ndarray, displacement: np.ndarray) -> np.ndarray:
        """Gauss-Newton Hessian of ``D`` at ``points`` applied to a ``displacement`` ``(k, d)``.

        For a least-squares term ``2 J_r^T J_r displacement`` with ``J_r`` the
        residual's Jacobian (positive semi-definite); the Gauss-Newton solvers use it.
        """
        raise NotImplementedError(
            f"{type(self).__name__} has no Gauss-Newton Hessian (not a least-squares data term)"
        )

    def distance(self, points: np.ndarray) -> float:
        """``sqrt(D(x))``: the distance the term measures, in its own unit."""
        return float(np.sqrt(max(self.value(points), 0.0)))

    def linear_target(self, template: np.ndarray) -> np.ndarray | None:
        """Displacement of the template the linearised problem fits, or None.

        The registration starts from the minimiser of its linearisation
        ``phi_1(T) ~ T + K_xc mu`` when the term has one (a displacement per
        template point); otherwise from zero momenta.
        """
        return None

    def check_points(self, points: np.ndarray, expected_shape: tuple) -> None:
        """Raise a ``ValueError`` naming the term if ``points`` is not of ``expected_shape``."""
        if np.shape(points) != tuple(expected_shape):
            raise ValueError(
                f"{type(self).__name__}: deformed points of shape {tuple(expected_shape)} "
                f"expected, got {np.shape(points)}"
            )
