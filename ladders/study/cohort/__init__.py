"""Cohorts of corresponding meshes: the container, the synthetic model, folders and tables.

- :mod:`.cohort`: :class:`Cohort` and :class:`Subject`;
- :mod:`.synthetic_lv`: the synthetic left-ventricle model (:func:`make_synthetic_cohort`);
- :mod:`.mesh_folder`: a folder of mesh files (:func:`read_cohort`, :func:`write_cohort`);
- :mod:`.cohort_table`: a CSV table of subjects (:func:`read_cohort_table`);
- :mod:`.cohort_statistics`: anatomical figures of a cohort (:func:`cohort_statistics`);
- :mod:`.benchmark_shapes`: the registration benchmark's shapes (:func:`bent_ellipsoid`).
"""

from ..errors import CohortError, MeshFolderError, MissingAtlasError
from .benchmark_shapes import bent_ellipsoid
from .cohort import Cohort, Subject
from .cohort_statistics import CohortStatistics, cohort_statistics
from .cohort_table import read_cohort_table
from .mesh_folder import (
    UnusedMeshFilesWarning,
    assemble_cohort,
    read_cohort,
    warn_unused,
    write_cohort,
)
from .synthetic_lv import SubjectParameters, SyntheticLVModel, make_synthetic_cohort

__all__ = [
    "Cohort",
    "CohortError",
    "MeshFolderError",
    "MissingAtlasError",
    "Subject",
    "SubjectParameters",
    "SyntheticLVModel",
    "make_synthetic_cohort",
    "UnusedMeshFilesWarning",
    "assemble_cohort",
    "read_cohort",
    "warn_unused",
    "write_cohort",
    "read_cohort_table",
    "CohortStatistics",
    "cohort_statistics",
    "bent_ellipsoid",
]
