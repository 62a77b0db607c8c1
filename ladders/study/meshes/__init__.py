"""Mesh input and output: one triangle mesh per file, in the file's vertex order.

- :mod:`.mesh_io`: :func:`read_mesh` and :func:`write_mesh` (PLY, OBJ, STL, OFF, VTK,
  VTU, VTP);
- :mod:`.mesh_readers`: the readers behind :func:`read_mesh`;
- :mod:`.vtk_io`: legacy VTK polydata; :mod:`.vtk_xml`: VTK XML PolyData (``.vtp``);
- :mod:`.mesh_outputs`: the study's shapes and strain maps as ``.vtu`` files.
"""

from .mesh_io import (
    MESH_EXTENSIONS,
    OTHER_MESH_EXTENSIONS,
    WRITE_EXTENSIONS,
    read_mesh,
    write_mesh,
)
from .mesh_outputs import MESH_OUTPUT_FORMATS, write_point_mesh, write_subject_meshes
from .vtk_io import read_vtk, write_vtk
from .vtk_xml import read_vtp

__all__ = [
    "MESH_EXTENSIONS",
    "OTHER_MESH_EXTENSIONS",
    "WRITE_EXTENSIONS",
    "MESH_OUTPUT_FORMATS",
    "read_mesh",
    "write_mesh",
    "read_vtk",
    "write_vtk",
    "read_vtp",
    "write_point_mesh",
    "write_subject_meshes",
]
