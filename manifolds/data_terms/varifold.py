"""The varifold data term: unoriented surfaces compared without point correspondence.

A mesh with triangle centres ``c_i``, areas ``a_i`` and unit normals ``u_i`` is
the varifold ``sum_i a_i delta_{(c_i, +-u_i)}``; two meshes have the product
(Charon and Trouve 2013; Deformetrica's attachment ``"Varifold"``)::

    <A, B> = sum_ij exp(-|c_i - d_j|^2 / sigma_W^2) a_i b_j (u_i . v_j)^2,

quadratic in the normals' directions, so orientation does not matter and
opposite sheets do not cancel. ``||A - B||^2`` is zero for identical meshes and
invariant under rigid motions of both. A triangle of zero area has mass zero
and contributes nothing, nor to the gradient (its unit normal is set to zero,
see :func:`~manifolds.data_terms.mesh_geometry.unit_normals`).
"""

from __future__ import annotations

from .surface_distance import SurfaceDistance

__all__ = ["VarifoldDistance"]


class VarifoldDistance(SurfaceDistance):
    """``w ||A(x) - B||^2`` in the space of varifolds (see the module).

    Parameters are those of :class:`~manifolds.data_terms.surface_distance.SurfaceDistance`:
    ``(target_vertices, target_faces, template_faces, sigma_w, *, weight=1.0,
    n_points=None, backend="auto", block_size=None)``.
    """

    kind = "varifold"
