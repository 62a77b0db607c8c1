"""Change of variables of the registration's optimiser (``docs/lddmm.md``).

The optimiser works on ``z = R^T mu`` rather than on the momenta ``mu`` themselves.
With ``R R^T = K_xc^T K_xc + alpha^2 K_cc + eps I``, the Gauss-Newton Hessian of
the linearised registration problem (``phi_1(T) ~ T + K_xc mu``), the objective
is close to isotropic in ``z``, and the minimiser of the linearised problem is
the optimiser's start. Above :data:`PRECONDITION_MAX_CP` control points the full
factor is replaced by a diagonal scaling (:class:`DiagonalPreconditioner`), which
has no cheap linearised minimiser: the optimiser then starts from zero momenta.
Without preconditioning ``z = mu`` and the start is zero momenta as well.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from .kernels import GaussianKernel

__all__ = [
    "Preconditioner",
    "IdentityPreconditioner",
    "CholeskyPreconditioner",
    "DiagonalPreconditioner",
    "make_preconditioner",
    "PRECONDITION_MAX_CP",
]

PRECONDITION_MAX_CP = 4000  # largest n_cp for the full Cholesky preconditioner


class Preconditioner:
    """Linear change of variables ``z = R^T mu`` between momenta and optimiser variables.

    Subclasses implement :meth:`to_momenta`, :meth:`to_variables` and
    :meth:`gradient_to_variables` (the chain rule ``dC/dz = R^{-1} dC/dmu``),
    and may provide :meth:`linearised_start`.
    """

    def to_momenta(self, z: np.ndarray) -> np.ndarray:
        """``mu = R^{-T} z``, shape ``(n_cp, d)``."""
        raise NotImplementedError

    def to_variables(self, mu: np.ndarray) -> np.ndarray:
        """``z = R^T mu``, shape ``(n_cp, d)``."""
        raise NotImplementedError

    def gradient_to_variables(self, g_mu: np.ndarray) -> np.ndarray:
        """Gradient with respect to ``z`` from the gradient with respect to ``mu``."""
        raise NotImplementedError

    def linearised_start(self, kernel, template, displacement, control_points) -> np.ndarray:
        """Start of the optimiser, shape ``(n_cp, d)`` (zero momenta by default).

        ``displacement`` (``(k, d)`` or None) is what the linearised problem fits
        (``S - T`` for a target in correspondence).
        """
        return np.zeros(control_points.shape)


class IdentityPreconditioner(Preconditioner):
    """``z = mu``: plain L-BFGS-B on the momenta."""

    def to_momenta(self, z):
        return z

    def to_variables(self, mu):
        return mu

    def gradient_to_variables(self, g_mu):
        return g_mu


class CholeskyPreconditioner(Preconditioner):
    """``R`` the lower Cholesky factor of the linearised Gauss-Newton Hessian.

    Parameters
    ----------
    kernel : GaussianKernel
    template : array, shape ``(k, d)``
    control_points : array, shape ``(n_cp, d)``
    alpha : float
    dense : bool
        Whether the control points are the template's vertices (``K_xc = K_cc``,
        :func:`manifolds.lddmm.control_points.is_dense`).
    rel_ridge : float
        ``eps`` relative to the mean of the diagonal.
    """

    def __init__(self, kernel, template, control_points, alpha, dense, rel_ridge):
        k_cc = kernel.matrix(control_points)
        k_xc = k_cc if dense else kernel.matrix(template, control_points)
        gram = k_xc.T @ k_xc
        gram += alpha**2 * k_cc
        del k_cc, k_xc
        eps = rel_ridge * float(np.trace(gram)) / gram.shape[0]
        gram[np.diag_indices_from(gram)] += eps
        chol = scipy.linalg.cholesky(gram, lower=True, overwrite_a=True, check_finite=False)
        self.chol = np.ascontiguousarray(chol)
        self.kernel = kernel

    def to_momenta(self, z):
        return self.kernel.solve_triangular(self.chol, z, transpose=True)

    def to_variables(self, mu):
        return self.chol.T @ mu

    def gradient_to_variables(self, g_mu):
        return self.kernel.solve_triangular(self.chol, g_mu, transpose=False)

    def linearised_start(self, kernel, template, displacement, control_points):
        """Minimiser of the linearised problem, ``(R R^T)^{-1} K_xc^T (S - T)``
        (zero momenta when ``displacement`` is None)."""
        if displacement is None:
            return np.zeros(control_points.shape)
        rhs = kernel.convolve(control_points, template, displacement)
        return scipy.linalg.cho_solve((self.chol, True), rhs, check_finite=False)


class DiagonalPreconditioner(Preconditioner):
    """``R`` diagonal: the square root of the Gauss-Newton Hessian's diagonal.

    ``diag_i = sum_x K(x, c_i)^2 + alpha^2``; ``K^2`` is the Gaussian kernel of
    width ``sigma / sqrt(2)``, so the sums need no kernel matrix.
    """

    def __init__(self, kernel: GaussianKernel, template, control_points, alpha):
        k2 = kernel.with_sigma(kernel.sigma / np.sqrt(2.0))
        diag = k2.convolve(control_points, template, np.ones((template.shape[0], 1)))[:, 0]
        diag += alpha**2
        self.diag = np.sqrt(np.maximum(diag, 1e-12 * diag.max(initial=1.0)))[:, None]

    def to_momenta(self, z):
        return z / self.diag

    def to_variables(self, mu):
        return mu * self.diag

    def gradient_to_variables(self, g_mu):
        return g_mu / self.diag


def make_preconditioner(
    kernel: GaussianKernel,
    template: np.ndarray,
    control_points: np.ndarray,
    alpha: float,
    dense: bool,
    precondition: bool = True,
    rel_ridge: float = 1e-2,
) -> Preconditioner:
    """The preconditioner :func:`manifolds.lddmm.register` uses for these arguments."""
    if not precondition:
        return IdentityPreconditioner()
    if control_points.shape[0] <= PRECONDITION_MAX_CP:
        return CholeskyPreconditioner(kernel, template, control_points, alpha, dense, rel_ridge)
    return DiagonalPreconditioner(kernel, template, control_points, alpha)
