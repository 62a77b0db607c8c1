"""Data terms of registrations: functions of the deformed template's points.

- :mod:`.base`: :class:`DataTerm`, the interface (value, gradient with respect to
  the deformed points, residual of least-squares terms);
- :mod:`.landmarks`: :class:`SquaredDistance`, points in correspondence (eq. 3);
- meshes without correspondence: :class:`CurrentDistance` (:mod:`.current`) and
  :class:`VarifoldDistance` (:mod:`.varifold`), built on :mod:`.surface_distance`,
  the triangle geometry of :mod:`.mesh_geometry` and the kernel sums of
  :mod:`.surface_kernels` (numpy reference) and :mod:`.surface_kernels_numba`.
"""

from .base import DataTerm
from .current import CurrentDistance
from .landmarks import SquaredDistance
from .mesh_geometry import triangle_geometry, triangle_geometry_vjp, unit_normals
from .surface_distance import SurfaceDistance, surface_features
from .varifold import VarifoldDistance

__all__ = [
    "DataTerm",
    "SquaredDistance",
    "SurfaceDistance",
    "CurrentDistance",
    "VarifoldDistance",
    "surface_features",
    "triangle_geometry",
    "triangle_geometry_vjp",
    "unit_normals",
]
