"""From segmentations to a cohort in correspondence: units, alignment, correspondence, atlas.

- :mod:`.units`: :func:`check_units_and_pose`, sizes and poses against the atlas's;
  :mod:`.cohort_units`: :func:`check_cohort_units` (a cohort in correspondence) and
  :func:`read_atlas_inputs` (the ED meshes of a folder, for an atlas), in one unit;
- :mod:`.alignment`: :class:`SimilarityTransform`, :func:`procrustes` (with
  correspondence) and :func:`icp_align` (without); :mod:`.rigid_fit`:
  :func:`fit_rigid`, the alignment that keeps the input's turn about the long axis
  or follows anatomical landmarks (:mod:`.landmarks`: :class:`Landmarks`, the table); :mod:`.affine`: the affine
  pre-alignment of the atlas (:func:`affine_icp`);
- :mod:`.correspondence`: :func:`correspond_mesh` and :func:`correspond_subject`,
  the atlas registered onto a mesh of any triangulation with a varifold term, with
  its settings in :mod:`.correspondence_settings` (:class:`CorrespondenceSettings`);
- :mod:`.cohort_correspondence`: :func:`correspond_cohort`, a folder of
  segmentations into a folder the study reads, with a quality table
  (:mod:`.quality_table`), failures recorded and resume;
- :mod:`.atlas`: :func:`estimate_atlas`, the LDDMM atlas of end-diastolic meshes, its
  registrations run in parallel by :mod:`.atlas_registrations` (:class:`AtlasLogs`);
  :mod:`.atlas_subset`: :func:`choose_atlas_subset`, the subjects an atlas of a large
  cohort is estimated from; :mod:`.atlas_run`: :func:`build_atlas`, the atlas of a
  folder written with its record (:mod:`.atlas_record`; what ``symladders atlas``
  runs), reused when it is there with the same key;
- :mod:`.surface_distance`: Hausdorff and mean surface distances;
- :mod:`.remeshing`: :func:`remesh`, another triangulation of a surface;
  :mod:`.simulation`: :func:`simulate_segmentations` of a cohort (tests, tutorial).
"""

from .affine import affine_icp, apply_affine
from .alignment import (
    SimilarityTransform,
    icp_align,
    principal_frame,
    procrustes,
    random_rigid_transform,
    second_moments,
)
from .atlas import AtlasResult, estimate_atlas, meshes_correspond
from .atlas_registrations import AtlasLogs, AtlasRegistration
from .atlas_run import AtlasInterrupted, AtlasRun, build_atlas
from .atlas_subset import SUBSET_RULES, AtlasSubset, choose_atlas_subset, shape_descriptor
from .cohort_correspondence import CohortCorrespondence, correspond_cohort, scan_segmentations
from .cohort_units import AtlasInputs, check_cohort_units, read_atlas_inputs
from .correspondence import (
    MeshCorrespondence,
    SubjectCorrespondence,
    correspond_mesh,
    correspond_subject,
    project_mesh,
)
from .correspondence_settings import CorrespondenceSettings
from .landmarks import (
    LANDMARKS_FILE,
    LandmarkError,
    Landmarks,
    landmark_transform,
    read_landmarks,
    write_landmarks,
)
from .quality_table import quality_rows, write_quality_table
from .remeshing import remesh
from .rigid_fit import AlignmentFit, fit_rigid
from .simulation import (
    procrustes_aligned,
    recovery_errors,
    simulate_segmentations,
    vertex_error_components,
)
from .surface_distance import distances_to_surface, surface_distances
from .units import (
    UNITS_IN_MM,
    MeshSize,
    UnitsError,
    UnitsReport,
    check_units_and_pose,
    mesh_size,
)

__all__ = [
    "affine_icp",
    "apply_affine",
    "SimilarityTransform",
    "procrustes",
    "icp_align",
    "principal_frame",
    "second_moments",
    "random_rigid_transform",
    "AtlasResult",
    "estimate_atlas",
    "build_atlas",
    "AtlasRun",
    "AtlasInterrupted",
    "AtlasLogs",
    "AtlasRegistration",
    "AtlasSubset",
    "SUBSET_RULES",
    "choose_atlas_subset",
    "shape_descriptor",
    "meshes_correspond",
    "AtlasInputs",
    "read_atlas_inputs",
    "CohortCorrespondence",
    "correspond_cohort",
    "scan_segmentations",
    "CorrespondenceSettings",
    "MeshCorrespondence",
    "SubjectCorrespondence",
    "correspond_mesh",
    "correspond_subject",
    "project_mesh",
    "LANDMARKS_FILE",
    "LandmarkError",
    "Landmarks",
    "landmark_transform",
    "read_landmarks",
    "write_landmarks",
    "AlignmentFit",
    "fit_rigid",
    "quality_rows",
    "write_quality_table",
    "remesh",
    "simulate_segmentations",
    "recovery_errors",
    "vertex_error_components",
    "procrustes_aligned",
    "distances_to_surface",
    "surface_distances",
    "UNITS_IN_MM",
    "MeshSize",
    "UnitsError",
    "UnitsReport",
    "check_units_and_pose",
    "check_cohort_units",
    "mesh_size",
]
