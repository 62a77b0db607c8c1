"""Cohorts of corresponding meshes: the container, the synthetic model, folders and tables.

- :mod:`.cohort`: :class:`Cohort` and :class:`Subject`;
- :mod:`.synthetic_lv`: the synthetic left-ventricle model (:func:`make_synthetic_cohort`);
- :mod:`.mesh_folder`: a folder of mesh files (:func:`read_cohort`, :func:`write_cohort`);
- :mod:`.cohort_table`: a CSV table of subjects (:func:`read_cohort_table`);
- :mod:`.cohort_statistics`: anatomical figures of a cohort (:func:`cohort_statistics`);
- :mod:`.benchmark_shapes`: the registration benchmark's shapes (:func:`bent_ellipsoid`);
- :mod:`.aha_segments`: the AHA 17-segment model on the synthetic ventricle;
- :mod:`.planted_effect`: a regional motion abnormality and its ground truth on the atlas;
- :mod:`.segmentation_noise`: smooth random normal displacements of a surface;
- :mod:`.groups_table`: the ``subject,group`` table;
- :mod:`.analytic_ventricle`: :class:`AnalyticVentricle`, a cavity of known motion in
  closed form (label images, a mesh, the valve plane of every frame), independent of
  the synthetic model: a ground truth for the tracking;
- :mod:`.cardiac_cycle`: the whole cycle, a time course and a motion of the volume
  (:func:`cycle_frames`, :func:`motion_forward`, :func:`motion_inverse`); a two-group
  cohort's cycles are in :mod:`ladders.study.population.cycle_cohort`.
"""

from ..errors import CohortError, MeshFolderError, MissingAtlasError
from .aha_segments import AHA_SEGMENTS, segment_of, segment_weights
from .analytic_ventricle import AnalyticVentricle
from .benchmark_shapes import bent_ellipsoid
from .cardiac_cycle import (
    check_invertible,
    cycle_fraction,
    cycle_frames,
    frame_abnormality,
    frame_times,
    motion_forward,
    motion_inverse,
)
from .cohort import Cohort, Subject
from .cohort_statistics import CohortStatistics, cohort_statistics
from .cohort_table import read_cohort_table
from .groups_table import groups_csv, read_groups
from .mesh_folder import (
    UnusedMeshFilesWarning,
    assemble_cohort,
    read_cohort,
    warn_unused,
    write_cohort,
)
from .planted_effect import (
    EFFECT_KINDS,
    MotionAbnormality,
    PlantedRegion,
    planted_modulation,
    planted_region,
)
from .segmentation_noise import smooth_normal_noise
from .synthetic_lv import (
    MotionModulation,
    SubjectParameters,
    SyntheticLVModel,
    make_synthetic_cohort,
)

__all__ = [
    "AnalyticVentricle",
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
    "AHA_SEGMENTS",
    "segment_of",
    "segment_weights",
    "EFFECT_KINDS",
    "MotionAbnormality",
    "MotionModulation",
    "PlantedRegion",
    "planted_modulation",
    "planted_region",
    "smooth_normal_noise",
    "groups_csv",
    "read_groups",
    "check_invertible",
    "cycle_fraction",
    "cycle_frames",
    "frame_abnormality",
    "frame_times",
    "motion_forward",
    "motion_inverse",
]
