"""The registration benchmark's shapes: an ellipsoid mesh and its bent-and-twisted copy."""

from __future__ import annotations

import numpy as np
import trimesh

__all__ = ["bent_ellipsoid"]


def bent_ellipsoid(subdivisions: int = 3, twist: float = 0.4, bend: float = 0.2):
    """Icosphere scaled to semi-axes ``(1, 0.7, 0.5)`` and a smoothly deformed copy.

    The copy is ``(x, y, z) -> (x, R(twist x)(y, z) + (0, 0, bend x^2))``: a twist
    about the long axis and a bend. ``subdivisions`` 2, 3, 4, 5 give 162, 642,
    2,562 and 10,242 vertices.

    Returns
    -------
    template, target : arrays, shape ``(k, 3)``
    faces : int array, shape ``(f, 3)``
    """
    mesh = trimesh.creation.icosphere(subdivisions=subdivisions)
    template = np.asarray(mesh.vertices) * np.array([1.0, 0.7, 0.5])
    x, y, z = template.T
    angle = twist * x
    y2 = np.cos(angle) * y - np.sin(angle) * z
    z2 = np.sin(angle) * y + np.cos(angle) * z + bend * x**2
    return template, np.stack([x, y2, z2], axis=1), np.asarray(mesh.faces)
