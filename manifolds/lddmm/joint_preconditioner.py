"""Change of variables for registrations over control points and momenta together (eq. 3).

When the control points ``c`` are optimised with the momenta ``mu``, their scales
differ by orders of magnitude: moving a control point by 1 mm changes the
deformation in proportion to its momentum, so the curvature along ``c_j`` grows
like ``|mu_j|^2`` and vanishes for a control point without momentum, while the
curvature along the momenta is that of the fixed-point problem. A quasi-Newton
method started with a scaled identity then creeps along the stiff and the flat
directions alike (``docs/evidence/developer_notes.md`` measures it).

:class:`JointPreconditioner` whitens both with the Gauss-Newton matrix of the
linearised deformation at the current iterate: with
``phi_1(T) ~ T + sum_j K(T, c_j) mu_j``,

    J_mu = K(T, c) (x) I_d,   (J_c)_{ij} = K(T_i, c_j) (2 / sigma^2) mu_j (T_i - c_j)^T,
    M = [J_mu J_c]^T [J_mu J_c] + alpha^2 (K(c, c) (x) I_d on the momenta block),

plus a ridge on each block (``rel_ridge`` times the block's mean diagonal, and on
the control points at least the momenta's ridge divided by ``sigma^2``), and
``x = L^T w`` for ``w = (mu, c)`` and ``M = L L^T``. The matrix depends on ``mu``
and ``c``: the solver rebuilds it every ``RegistrationSettings.refresh_every``
iterations (:meth:`manifolds.lddmm.RegistrationProblem.refresh`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

__all__ = ["JointPreconditioner", "linearised_joint_gram"]


def linearised_joint_gram(kernel, template, control_points, momenta, alpha, rel_ridge):
    """The matrix ``M`` of the module docstring, shape ``(2 n d, 2 n d)`` (``w = (mu, c)``)."""
    t = np.asarray(template, dtype=float)
    c = np.asarray(control_points, dtype=float)
    mu = np.asarray(momenta, dtype=float)
    (k, d), n = t.shape, c.shape[0]
    kx = kernel.matrix(t, c)  # (k, n)
    j_mu = np.kron(kx, np.eye(d))  # (k d, n d)
    diff = t[:, None, :] - c[None, :, :]  # (k, n, d)
    w = (2.0 * kernel.inv_s2) * kx[:, :, None, None] * mu[None, :, :, None] * diff[:, :, None, :]
    j_c = w.transpose(0, 2, 1, 3).reshape(k * d, n * d)
    jac = np.hstack([j_mu, j_c])
    gram = jac.T @ jac
    nd = n * d
    gram[:nd, :nd] += alpha**2 * np.kron(kernel.matrix(c), np.eye(d))
    mu_block, c_block = gram[:nd, :nd], gram[nd:, nd:]
    eps_mu = rel_ridge * float(np.trace(mu_block)) / nd
    # With small momenta the control-point block vanishes with them: its ridge is at
    # least that of the momenta block per sigma^2 (a control point moved by sigma
    # changes the field as much as a unit change of its momentum).
    eps_c = max(rel_ridge * float(np.trace(c_block)) / nd, eps_mu * kernel.inv_s2)
    mu_block[np.diag_indices_from(mu_block)] += eps_mu if eps_mu > 0 else 1.0
    c_block[np.diag_indices_from(c_block)] += eps_c if eps_c > 0 else 1.0
    return gram


class JointPreconditioner:
    """``x = L^T (mu, c)`` with ``L L^T`` the linearised Gauss-Newton matrix (module docstring).

    Parameters
    ----------
    kernel : GaussianKernel
    template : array, shape ``(k, d)``
    control_points, momenta : arrays, shape ``(n_cp, d)``
        The iterate the matrix is built at.
    alpha : float
    rel_ridge : float
    """

    def __init__(self, kernel, template, control_points, momenta, alpha, rel_ridge):
        gram = linearised_joint_gram(kernel, template, control_points, momenta, alpha, rel_ridge)
        self.chol = scipy.linalg.cholesky(gram, lower=True, check_finite=False)
        self.shape = np.shape(control_points)

    def to_variables(self, mu, control_points) -> np.ndarray:
        """``x = L^T (mu, c)``, flat."""
        w = np.concatenate([np.ravel(mu), np.ravel(control_points)])
        return self.chol.T @ w

    def to_natural(self, x):
        """``(mu, c)`` of ``x``."""
        w = scipy.linalg.solve_triangular(self.chol, x, lower=True, trans="T", check_finite=False)
        mu, c = np.split(w, 2)
        return mu.reshape(self.shape), c.reshape(self.shape)

    def gradient_to_variables(self, g_mu, g_c) -> np.ndarray:
        """Gradient with respect to ``x``: ``L^{-1} (g_mu, g_c)``."""
        g = np.concatenate([np.ravel(g_mu), np.ravel(g_c)])
        return scipy.linalg.solve_triangular(self.chol, g, lower=True, check_finite=False)
