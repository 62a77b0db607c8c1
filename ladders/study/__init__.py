"""The paper's application (Section 3), built on :mod:`manifolds` and :mod:`ladders`.

Sub-packages, by concern:

- :mod:`.meshes`: mesh input/output (:func:`read_mesh`, :func:`write_mesh`, legacy
  VTK, VTK XML PolyData) and the study's mesh outputs (:func:`write_subject_meshes`);
- :mod:`.cohort`: cohorts (:class:`Cohort`), the synthetic left-ventricle model
  (:func:`make_synthetic_cohort`), mesh folders (:func:`read_cohort`), cohort tables
  (:func:`read_cohort_table`), cohort figures and the registration benchmark's shapes
  (:func:`bent_ellipsoid`);
- :mod:`.deformations`: the deformation models the study runs on
  (:class:`DeformationModel`, the built-in ``lddmm`` and ``svf``, any a user
  registers with :func:`register_deformation`) and their checks
  (:func:`validate_deformation_model`);
- :mod:`.running`: the study's computation (:class:`StudyConfig`, :func:`compute_pair`,
  the one computation of a (subject, ``alpha^2``) pair, and :func:`run_subject`), its
  typed results (:class:`PairResult`, :class:`SubjectResults`), the runner with its
  resumable store (:func:`run_study`) and the manifest;
- :mod:`.reporting`: the report (:func:`summarize`, :func:`write_report`,
  :func:`tidy_rows`, :func:`paired_statistics`), the figures and the comparison
  of deformation models;
- :mod:`.wall`: wall thickness, thickening and strain per vertex and AHA segment, from
  the tracked endocardium and epicardium;
- :mod:`.cli`: the ``symladders`` command line.

Beside them: local area strain (:func:`area_strain`, :func:`area_strain_error`),
the normal wall motion (:func:`normal_wall_motion`), the rotation about the long axis
and the twist (:func:`rotation_about_axis`, :func:`twist_angle`), enclosed volumes
(:mod:`.volume`), the analytic validation run (:func:`run_validation`),
:func:`run`, the study in one call (:mod:`.study_run`), and :mod:`.population`, the
group statistics of transported motion.
"""

from .analytic_validation import ValidationReport, run_validation
from .area_strain import area_strain, area_strain_error, cell_areas
from .cohort import (
    Cohort,
    CohortError,
    CohortStatistics,
    MeshFolderError,
    Subject,
    SubjectParameters,
    SyntheticLVModel,
    UnusedMeshFilesWarning,
    bent_ellipsoid,
    cohort_statistics,
    make_synthetic_cohort,
    read_cohort,
    read_cohort_table,
    write_cohort,
)
from .deformations import (
    DeformationModel,
    DeformationModelError,
    Registration,
    Transported,
    check_deformation_model,
    deformation_model,
    deformation_names,
    register_deformation,
    validate_deformation_model,
)
from .meshes import (
    MESH_EXTENSIONS,
    read_mesh,
    read_vtk,
    read_vtp,
    write_mesh,
    write_point_mesh,
    write_subject_meshes,
    write_vtk,
)
from .reporting import (
    compare_deformations,
    comparison_markdown,
    paired_comparison,
    paired_statistics,
    summarize,
    summary_markdown,
    tidy_rows,
    write_report,
)
from .running import (
    ERROR_NAMES,
    VARIANTS,
    FailedPair,
    PairResult,
    StudyConfig,
    SubjectResults,
    compute_pair,
    run_study,
    run_subject,
)
from .wall_motion import normal_wall_motion
from .wall_rotation import rotation_about_axis, twist_angle

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
    "normal_wall_motion",
    "rotation_about_axis",
    "twist_angle",
    "bent_ellipsoid",
    "ERROR_NAMES",
    "VARIANTS",
    "DeformationModel",
    "DeformationModelError",
    "Registration",
    "Transported",
    "check_deformation_model",
    "deformation_model",
    "deformation_names",
    "register_deformation",
    "validate_deformation_model",
    "StudyConfig",
    "run_subject",
    "run_study",
    "compute_pair",
    "PairResult",
    "FailedPair",
    "SubjectResults",
    "tidy_rows",
    "paired_comparison",
    "paired_statistics",
    "summarize",
    "summary_markdown",
    "write_report",
    "ValidationReport",
    "run_validation",
    "StudyRun",
    "run",
]

from .study_run import StudyRun, run  # noqa: E402  (the facade, above every sub-package)
