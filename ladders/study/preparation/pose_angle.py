"""How far a mesh is turned from the atlas's orientation, defined for near-round shapes too.

The angle between the principal axes (of largest variance) of two surfaces is
arbitrary when a surface is near round: a left ventricle whose two largest
second moments differ by a few per cent has its "long axis" anywhere in their
plane, and an unposed subject can read as turned by 60 degrees. Two measures
that stay defined are used instead:

* **In correspondence** (the mesh has the atlas's triangulation, as a cohort in
  correspondence does): the rotation angle of the least-squares rigid fit of the
  mesh's vertices onto the atlas's (:func:`~.alignment.procrustes`, Kabsch). The
  correspondence fixes the rotation whatever the shape.
* **Otherwise** (another triangulation): the second-moment tensors
  (:func:`~.alignment.second_moments`), each divided by its trace (the shapes' size
  removed), are compared whole. With ``A`` the atlas's and ``S`` the mesh's, of
  eigenvalues ``a_1 >= a_2 >= a_3`` and ``s_1 >= s_2 >= s_3``, their orientation misfit
  ``e = sum_i a_i s_i - trace(A S) >= 0`` (von Neumann's trace inequality; zero iff
  the tensors share their eigenvectors in the same order) is what a rotation of
  ``S`` could remove from ``|S - A|^2 / 2``. The angle reported is
  ``arcsin sqrt(min(1, e / (d_A max(d_A, d_S))))`` with ``d = a_1 - a_3`` the
  anisotropy: for two prolate axisymmetric shapes at least as elongated as the atlas it is the
  angle between their long axes (``e = d_A d_S sin^2``); a rounder mesh turned by
  ``t`` reads as ``arcsin sqrt(d_S / d_A sin^2 t)``, smaller in proportion to how
  much orientation its moments carry, and a round one (``d_S = 0``) as 0: its turn
  cannot be seen from its moments, and it is no longer taken from an arbitrary axis.
  An isotropic atlas (``d_A = 0``) gives 0 too.
"""

from __future__ import annotations

import numpy as np

from .alignment import procrustes, second_moments

__all__ = ["moments_angle", "pose_angle"]

#: What each measure is called in the messages.
MEASURES = {
    "correspondence": "rigid fit of the corresponding vertices",
    "moments": "second moments",
}


def moments_angle(moments, atlas_moments) -> float:
    """The orientation misfit of two second-moment tensors as an angle (see the module).

    Parameters
    ----------
    moments, atlas_moments : arrays ``(3, 3)``
        Symmetric positive semi-definite tensors (any scale: each is divided by its trace).

    Returns
    -------
    float
        Degrees, in ``[0, 90]``.
    """
    s = np.asarray(moments, dtype=float) / np.trace(moments)
    a = np.asarray(atlas_moments, dtype=float) / np.trace(atlas_moments)
    s_eig, a_eig = np.linalg.eigvalsh(s), np.linalg.eigvalsh(a)  # both ascending
    misfit = max(0.0, float(s_eig @ a_eig - np.sum(s * a)))
    d_atlas, d_mesh = a_eig[-1] - a_eig[0], s_eig[-1] - s_eig[0]
    if d_atlas <= 1e-12:
        return 0.0
    ratio = min(1.0, misfit / (d_atlas * max(d_atlas, d_mesh)))
    return float(np.degrees(np.arcsin(np.sqrt(ratio))))


def pose_angle(vertices, faces, atlas_vertices, atlas_faces) -> tuple[float, str]:
    """How far ``(vertices, faces)`` is turned from the atlas, and by which measure.

    Parameters
    ----------
    vertices, faces : arrays ``(n, 3)``, ``(f, 3)``
    atlas_vertices, atlas_faces : arrays ``(k, 3)``, ``(g, 3)``

    Returns
    -------
    angle : float
        Degrees (see the module).
    measure : {"correspondence", "moments"}
        ``"correspondence"`` when the mesh has the atlas's faces (and vertex count).
    """
    if len(vertices) == len(atlas_vertices) and np.array_equal(faces, atlas_faces):
        return procrustes(vertices, atlas_vertices).rotation_angle(), "correspondence"
    angle = moments_angle(second_moments(vertices, faces)[1],
                          second_moments(atlas_vertices, atlas_faces)[1])  # fmt: skip
    return angle, "moments"
