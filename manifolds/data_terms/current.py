"""The current data term: oriented surfaces compared without point correspondence.

A mesh with triangle centres ``c_i`` and area-weighted normals ``n_i`` is the
current ``sum_i n_i delta_{c_i}``; two meshes have the product::

    <A, B> = sum_ij exp(-|c_i - d_j|^2 / sigma_W^2) n_i . m_j

(Glaunes and Vaillant 2005; Deformetrica's attachment ``"Current"``). The
distance ``||A - B||^2`` is zero for identical meshes, invariant under a
rigid motion of both, and sees orientation: flipping the target's normals
turns ``<A, B>`` into ``-<A, B>``. Opposite sheets closer than ``sigma_W``
cancel, which makes the term blind to thin folds; :mod:`.varifold` does not.
"""

from __future__ import annotations

from .surface_distance import SurfaceDistance

__all__ = ["CurrentDistance"]


class CurrentDistance(SurfaceDistance):
    """``w ||A(x) - B||^2`` in the space of currents (see the module).

    Parameters are those of :class:`~manifolds.data_terms.surface_distance.SurfaceDistance`:
    ``(target_vertices, target_faces, template_faces, sigma_w, *, weight=1.0,
    n_points=None, backend="auto", block_size=None)``.
    """

    kind = "current"
