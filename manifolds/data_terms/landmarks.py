"""The data term of shapes in correspondence: the squared distance between matching points."""

from __future__ import annotations

import numpy as np

from ..validation import check_array
from .base import DataTerm

__all__ = ["SquaredDistance"]


class SquaredDistance(DataTerm):
    """``D(x) = ||S - x||_F^2``, the sum of squared distances of corresponding points.

    The data term of the paper's eq. (3) for meshes in vertex correspondence.
    Its residual ``S - x`` is the displacement ``delta`` of eq. (4).

    Parameters
    ----------
    target : array, shape ``(k, d)``
        The target shape ``S``, one point per template point.
    """

    least_squares = True
    corresponds = True

    def __init__(self, target):
        self.target = check_array(target, (), "SquaredDistance: target")
        if self.target.ndim != 2:
            raise ValueError(
                f"SquaredDistance: target: expected points of shape (k, d), got {self.target.shape}"
            )

    def __repr__(self) -> str:
        return f"SquaredDistance(target of shape {self.target.shape})"

    def residual(self, points):
        """``delta = S - x``, shape ``(k, d)``."""
        self.check_points(points, self.target.shape)
        return self.target - points

    def value_and_gradient(self, points):
        resid = self.residual(points)
        return float((resid * resid).sum()), -2.0 * resid

    def value(self, points):
        resid = self.residual(points)
        return float((resid * resid).sum())

    def gauss_newton_product(self, points, displacement):
        """``2 displacement``: the residual's Jacobian is ``-I``, and ``D`` is quadratic."""
        return 2.0 * np.asarray(displacement, dtype=float)

    def linear_target(self, template):
        """``S - T``: the linearised problem fits the target's displacement."""
        return self.target - np.asarray(template, dtype=float)
