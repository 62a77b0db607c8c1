"""Symmetry error estimators of the paper (Sections 2.3, 2.4 and 3).

Each estimator measures how far a numerical implementation of the midpoint and
of the geodesic symmetry ``s_M(S) = Exp_M(-Log_M(S))`` is from the properties
that hold exactly in an affine symmetric space:

* midpoint distance: ``d(Exp_T(1/2 Log_T S), Exp_S(1/2 Log_S T))``;
* centrality: ``d(s_M(T), S)`` with ``M`` the midpoint shot from ``T``;
* involutivity: ``d(s_M(s_M(S')), S')``;
* transvectivity: ``d(s_T o s_M(S'), s_M o s_S(S'))`` (eq. 8 of the paper).

The distance is a parameter (:func:`manifolds.point_distance.point_distance`):
``"rms"`` (default), the paper's unit, is the root mean square distance between
corresponding vertices, ``||S_1 - S_2||_F / sqrt(k)`` for shapes of ``k``
vertices (the rows of a ``(k, d)`` point); ``"frobenius"`` is ``||S_1 - S_2||_F``;
``"mean"`` the mean per-vertex Euclidean distance; a callable ``(a, b) -> float``
is used as given. For 1-D points (one vertex) the three coincide; for other
shapes the last axis holds a vertex's coordinates and the leading axes index
the vertices.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from manifolds.connection import Connection
from manifolds.point_distance import point_distance

__all__ = [
    "midpoint_distance",
    "centrality_error",
    "involutivity_error",
    "transvectivity_error",
    "SymmetryErrors",
    "symmetry_errors",
]

Distance = Callable[[np.ndarray, np.ndarray], np.ndarray] | str


def _check_space(space) -> None:
    if not isinstance(space, Connection):
        raise TypeError(f"space: expected a manifolds.Connection, got {type(space).__name__}")


def _distance(space, distance):
    """Check ``space`` and ``distance``; return the distance function to use."""
    _check_space(space)
    return point_distance("rms" if distance is None else distance, space.point_shape)


def _points(space, **points) -> None:
    """Check each point (shape, finiteness, membership) under the estimator's argument name."""
    for name, point in points.items():
        space.check_point(point, name)


def midpoint_distance(space, template, shape, distance: Distance = "rms"):
    """Distance between the midpoints shot from ``template`` and from ``shape``."""
    d = _distance(space, distance)
    _points(space, template=template, shape=shape)
    return d(space.midpoint(template, shape), space.midpoint(shape, template))


def centrality_error(space, template, shape, distance: Distance = "rms"):
    """Centrality ``d(s_M(T), S)`` with ``M = Exp_T(1/2 Log_T S)`` (paper, Section 2.3)."""
    d = _distance(space, distance)
    _points(space, template=template, shape=shape)
    m = space.midpoint(template, shape)
    return d(space.symmetry(m, template), shape)


def involutivity_error(space, center, point, distance: Distance = "rms"):
    """Involutivity ``d(s_M(s_M(P)), P)`` (paper, Section 2.4)."""
    d = _distance(space, distance)
    _points(space, center=center, point=point)
    return d(space.symmetry(center, space.symmetry(center, point)), point)


def transvectivity_error(space, template, shape, other, distance: Distance = "rms"):
    """Transvectivity ``d(s_T o s_M(S'), s_M o s_S(S'))`` with ``M`` the midpoint from ``T``.

    Zero in an affine symmetric space (eq. 8); otherwise its leading term is a
    covariant derivative of the curvature, ``nabla R`` (see ``docs/evidence/validation.md``).
    """
    d = _distance(space, distance)
    _points(space, template=template, shape=shape, other=other)
    m = space.midpoint(template, shape)
    ladder = space.transvection(template, m)(other)
    opposite = space.transvection(m, shape)(other)
    return d(ladder, opposite)


@dataclass
class SymmetryErrors:
    """The four errors of the paper's Section 3 for one triple ``(T, S, S')``.

    ``points`` holds the intermediate shapes: ``midpoint`` (``M``, shot from
    ``T``), ``reflected`` (``s_M(S')``) and ``pole_ladder`` (``T' = s_T(s_M(S'))``,
    the one-rung pole ladder of Algorithm 1).
    """

    midpoint_distance: np.ndarray
    centrality: np.ndarray
    involutivity: np.ndarray
    transvectivity: np.ndarray
    points: dict = field(default_factory=dict, repr=False, compare=False)

    def as_dict(self) -> dict:
        """The four errors as plain floats or lists (JSON-ready)."""
        return {k: np.asarray(v).tolist() for k, v in asdict(self).items() if k != "points"}


def symmetry_errors(
    space, template, shape, other, distance: Distance = "rms", warm_start: bool = False
) -> SymmetryErrors:
    """All four errors of Section 3, sharing intermediate results.

    Parameters
    ----------
    space : manifolds.Connection
    template : point ``T`` (the atlas)
    shape : point ``S`` (e.g. end-diastole)
    other : point ``S'`` (e.g. end-systole)
    distance : {"rms", "frobenius", "mean"} or callable, default "rms"
        Per-vertex RMS distance (the paper's unit), Frobenius norm, mean
        per-vertex distance, or a function ``(a, b) -> float``.
    warm_start : bool, default False
        Compute ``Log_M(s_M(S'))`` (involutivity) from its symmetric counterpart
        ``-Log_M(S')`` (:meth:`manifolds.Connection.symmetry_near`) instead of the
        space's cold start. Exact where ``log`` is (closed forms: no effect); for an
        iterative ``log`` it saves iterations, and the result is the minimiser the
        solver reaches from that start (``docs/evidence/developer_notes.md`` measures when the cold
        and warm errors agree).

    Returns
    -------
    SymmetryErrors
        ``midpoint_distance``, ``centrality``, ``involutivity`` (at the midpoint
        ``M`` shot from ``T``, applied to ``S'``) and ``transvectivity``.
    """
    d = _distance(space, distance)
    _points(space, template=template, shape=shape, other=other)
    m = space.midpoint(template, shape)
    m_from_shape = space.midpoint(shape, template)
    s_m_other = space.symmetry(m, other)
    ladder = space.symmetry(template, s_m_other)  # the transvection s_T o s_M at S' (pole ladder)
    if warm_start:
        twice = space.symmetry_near(m, s_m_other, -space.log(m, other))
    else:
        twice = space.symmetry(m, s_m_other)
    return SymmetryErrors(
        midpoint_distance=d(m, m_from_shape),
        centrality=d(space.symmetry(m, template), shape),
        involutivity=d(twice, other),
        transvectivity=d(ladder, space.transvection(m, shape)(other)),
        points={"midpoint": m, "reflected": s_m_other, "pole_ladder": ladder},
    )
