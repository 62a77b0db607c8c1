"""Data terms of registrations: functions of the deformed template's points.

- :mod:`.base`: :class:`DataTerm`, the interface (value, gradient with respect to
  the deformed points, residual of least-squares terms);
- :mod:`.landmarks`: :class:`SquaredDistance`, points in correspondence (eq. 3).
"""

from .base import DataTerm
from .landmarks import SquaredDistance

__all__ = ["DataTerm", "SquaredDistance"]
