"""The paper's application (Section 3), built on :mod:`manifolds` and :mod:`ladders`.

- cohorts: :class:`Cohort`, the synthetic left-ventricle model
  (:func:`make_synthetic_cohort`) and mesh folders (:func:`read_cohort`);
- mesh I/O (:func:`read_mesh`, :func:`write_mesh`, legacy VTK, VTK XML PolyData),
  cohort tables (:func:`read_cohort_table`) and the study's mesh outputs
  (:func:`write_subject_meshes`);
- local area strain (:func:`area_strain`, :func:`area_strain_error`);
- the study: per-subject pipeline (:func:`run_subject`), the runner with its
  resumable store (:func:`run_study`), the report (:func:`summarize`,
  :func:`write_report`, :func:`tidy_rows`, :func:`paired_statistics`) and the
  ``symladders`` command line (:mod:`.cli`);
- the analytic validation run (:func:`run_validation`) and the registration
  benchmark's shapes (:func:`bent_ellipsoid`).
"""

from .analytic_validation import ValidationReport, run_validation
from .area_strain import area_strain, area_strain_error, cell_areas
from .benchmark_shapes import bent_ellipsoid
from .cohort import Cohort, CohortError, MeshFolderError, Subject
from .cohort_statistics import CohortStatistics, cohort_statistics
from .cohort_table import read_cohort_table
from .deformation_comparison import compare_deformations, comparison_markdown
from .mesh_io import (
    MESH_EXTENSIONS,
    UnusedMeshFilesWarning,
    read_cohort,
    read_mesh,
    write_cohort,
    write_mesh,
)
from .mesh_outputs import write_point_mesh, write_subject_meshes
from .pipeline import ERROR_NAMES, VARIANTS, StudyConfig, run_subject
from .report import summarize, summary_markdown, write_report
from .runner import compute_pair, run_study
from .statistics import paired_comparison, paired_statistics, tidy_rows
from .synthetic_lv import SubjectParameters, SyntheticLVModel, make_synthetic_cohort
from .vtk_io import read_vtk, write_vtk
from .vtk_xml import read_vtp

__all__ = [
    "Cohort",
    "CohortError",
    "MeshFolderError",
    "Subject",
    "CohortStatistics",
    "compare_deformations",
    "comparison_markdown",
    "cohort_statistics",
    "SubjectParameters",
    "SyntheticLVModel",
    "make_synthetic_cohort",
    "MESH_EXTENSIONS",
    "read_cohort",
    "read_cohort_table",
    "UnusedMeshFilesWarning",
    "read_mesh",
    "write_cohort",
    "write_mesh",
    "read_vtk",
    "read_vtp",
    "write_point_mesh",
    "write_subject_meshes",
    "write_vtk",
    "area_strain",
    "area_strain_error",
    "cell_areas",
    "bent_ellipsoid",
    "ERROR_NAMES",
    "VARIANTS",
    "StudyConfig",
    "run_subject",
    "run_study",
    "compute_pair",
    "tidy_rows",
    "paired_comparison",
    "paired_statistics",
    "summarize",
    "summary_markdown",
    "write_report",
    "ValidationReport",
    "run_validation",
]
