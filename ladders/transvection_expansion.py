"""Leading ``nabla R`` terms of the two transvections of the paper's Section 2.4.

With ``M`` the midpoint of ``[T, S]``, ``u = Pi_S^M Log_S(S')`` and ``v = Log_M(T)``,
the pole ladder ``s_T o s_M`` and the opposite transvection ``s_M o s_S`` deviate
from parallel transport by (``R(X,Y)Z = nabla_X nabla_Y Z - nabla_Y nabla_X Z -
nabla_[X,Y] Z``)::

    u'  - u =  1/12 [ (nabla_v R)(u,v)(5u - 2v) + (nabla_u R)(u,v)(v - 2u) ] + O(5)
    u'' - u = -1/12 [ (nabla_v R)(u,v)(5u + 2v) + (nabla_u R)(u,v)(v + 2u) ] + O(5)
    u' - u'' = 1/12 [ 10 (nabla_v R)(u,v) u + 2 (nabla_u R)(u,v) v ]        + O(5)

The second line follows from the first applied to ``-u`` (``s_M o s_S`` is the
pole ladder of ``-u_S``); the paper prints ``5u + v`` there, a slip that the
measurements on the warped surface rule out (``docs/evidence/validation.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["NABLA_R_COEFFICIENTS", "TransvectionExpansion", "transvection_expansion"]

#: Coefficients of ``[(nabla_v R)(u,v)u, (nabla_v R)(u,v)v, (nabla_u R)(u,v)u,
#: (nabla_u R)(u,v)v] / 12`` in each deviation.
NABLA_R_COEFFICIENTS = {
    "pole_ladder": np.array([5.0, -2.0, -2.0, 1.0]),
    "opposite": np.array([-5.0, -2.0, -2.0, -1.0]),
    "transvectivity": np.array([10.0, 0.0, 0.0, 2.0]),
}


@dataclass
class TransvectionExpansion:
    """Measured deviations of the two transvections and the ``nabla R`` basis terms.

    Attributes
    ----------
    midpoint : array
        ``M``.
    u, v : arrays
        ``Pi_S^M Log_S(S')`` and ``Log_M(T)``.
    pole_deviation : array
        ``u' - u`` with ``u' = Pi_T^M Log_T(s_T s_M S')``.
    opposite_deviation : array
        ``u'' - u`` with ``u'' = Pi_T^M Log_T(s_M s_S S')``.
    terms : array, shape ``(dim, 4)``
        The four basis terms divided by 12 (order of :data:`NABLA_R_COEFFICIENTS`).
    """

    midpoint: np.ndarray
    u: np.ndarray
    v: np.ndarray
    pole_deviation: np.ndarray
    opposite_deviation: np.ndarray
    terms: np.ndarray

    def predicted(self, which: str) -> np.ndarray:
        """Leading term of ``"pole_ladder"``, ``"opposite"`` or ``"transvectivity"`` (u' - u'')."""
        return self.terms @ NABLA_R_COEFFICIENTS[which]

    def relative_error(self, which: str) -> float:
        """``|predicted - measured| / |measured|`` for one of the three deviations."""
        measured = {
            "pole_ladder": self.pole_deviation,
            "opposite": self.opposite_deviation,
            "transvectivity": self.pole_deviation - self.opposite_deviation,
        }[which]
        diff = self.predicted(which) - measured
        return float(np.linalg.norm(diff) / np.linalg.norm(measured))


def transvection_expansion(space, template, shape, other) -> TransvectionExpansion:
    """Measure both transvections of ``S'`` and evaluate the ``nabla R`` terms at ``M``.

    Needs a space with exact ``parallel_transport`` and ``curvature_derivative``
    (e.g. :class:`manifolds.MetricField`).

    Parameters
    ----------
    space : manifolds.Connection
    template, shape, other : points ``T``, ``S``, ``S'``
    """
    mid = space.midpoint(template, shape)
    ladder = space.symmetry(template, space.symmetry(mid, other))  # s_T o s_M (S')
    opposite = space.symmetry(mid, space.symmetry(shape, other))  # s_M o s_S (S')
    u = space.parallel_transport(shape, mid, space.log(shape, other))
    v = space.log(mid, template)
    u1 = space.parallel_transport(template, mid, space.log(template, ladder))
    u2 = space.parallel_transport(template, mid, space.log(template, opposite))

    def term(x, w):
        return np.asarray(space.curvature_derivative(mid, x, u, v, w)) / 12.0

    terms = np.stack([term(v, u), term(v, v), term(u, u), term(u, v)], axis=-1)
    return TransvectionExpansion(mid, u, v, u1 - u, u2 - u, terms)
