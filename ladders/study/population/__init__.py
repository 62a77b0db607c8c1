"""Population statistics of transported motion: two groups, where their motion differs, and truth.

- :mod:`.two_groups`: the synthetic cohort in two groups with a planted regional
  motion abnormality (:func:`make_two_group_cohort`, :func:`write_two_group_cohort`);
  :mod:`.cycle_cohort`: its whole cardiac cycle, every subject's frames and images
  (:func:`make_two_group_cycles`, :func:`two_group_cycles`; in several groups with
  covariates :func:`covariate_cycles`), written as 4-D label or cine images with
  :func:`write_cycle_cohort` (:mod:`.cycle_images`); :mod:`.cohort_outcome`: a survival
  outcome simulated from the true regional motion (:func:`cohort_outcome`);
- :mod:`.covariate_cohort`: the synthetic cohort in several groups (planted abnormalities,
  anatomy shifts) with age, sex and body size acting on the shapes, and its design table
  (:func:`make_covariate_cohort`, :func:`write_covariate_cohort`); :mod:`.ideal_transport`:
  each subject's own motion on the atlas's anatomy, what a transport should give
  (:func:`ideal_transport`, :func:`ideal_cycle_transport`, :func:`transport_error`);
- :mod:`.transported_motion`: the subjects' transported motion on the atlas, read
  from a study's results (:class:`TransportedMotion`, :func:`load_transported_motion`);
- :mod:`.group_comparison`: per-vertex tests with family-wise error control, a
  global test and a classifier (:func:`compare_groups`);
- :mod:`.against_truth`: power, Dice, AUC and the false-positive rate under the null
  of every transport (:func:`score_transports`);
- :mod:`.analysis`: the whole analysis of a study folder (:func:`analyze`), as
  ``symladders analyze`` runs it; :mod:`.analysis_outputs`: its files;
- :mod:`.aha_model`: the AHA 17 segments on any atlas mesh from three landmarks
  (:func:`aha_segments`); :mod:`.segment_table`: the groups compared per segment
  (:func:`segment_table`);
- :mod:`.model_comparison`: a linear model's contrast tested per vertex (covariates,
  several groups, TFCE) and per AHA segment (:func:`compare_model`);
  :mod:`.model_design`: a design table checked against a study's subjects, its
  contrasts and blocks (:func:`model_design`, shared with the whole cycle's analysis);
  :mod:`.model_analysis`: the analysis of a study folder with a design table
  (:func:`analyze_model`), as ``symladders analyze --design`` runs it;
  :mod:`.outcome_analysis`: survival predicted from every motion (:func:`analyze_outcome`,
  ``--outcome``).

The statistics themselves are generic and live in :mod:`ladders.statistics`.
"""

from .against_truth import (
    NullRate,
    TransportScore,
    null_false_positive_rate,
    read_scores_csv,
    score_transports,
    scores_csv,
    scores_markdown,
)
from .aha_model import AHA_NAMES, aha_segments, read_aha_landmarks
from .analysis import (
    AnalysisOutcome,
    analyze,
    check_groups_table,
    read_planted_region,
    select_motions,
)
from .analysis_outputs import write_analysis
from .cohort_outcome import cohort_outcome, regional_motion
from .covariate_cohort import (
    DESIGN_FILE,
    AnatomyShift,
    CohortGroup,
    CovariateCohort,
    Covariates,
    make_covariate_cohort,
    write_covariate_cohort,
)
from .cycle_cohort import (
    CYCLE_ABNORMALITY,
    CohortCycles,
    covariate_cycles,
    make_two_group_cycles,
    two_group_cycles,
)
from .cycle_images import (
    IMAGE_KINDS,
    VALVE_PLANES_FILE,
    cycle_grid,
    cycle_valve_planes,
    valve_planes,
    write_cycle_cohort,
)
from .group_comparison import NORMALIZATIONS, GroupComparison, compare_groups, normalize_motion
from .ideal_transport import (
    MOTION_PARAMETERS,
    ideal_cycle_transport,
    ideal_transport,
    transport_error,
)
from .model_analysis import ModelOutcome, analyze_model
from .model_comparison import MODEL_TESTS, ModelComparison, compare_model, model_responses
from .model_design import ModelDesign, check_design_table, groups_design, model_design
from .outcome_analysis import OutcomeOutcome, analyze_outcome, outcome_arrays, predict_outcome
from .segment_table import SegmentTable, segment_means, segment_table
from .transported_motion import (
    NO_TRANSPORT,
    StudyResults,
    TransportedMotion,
    load_study_results,
    load_transported_motion,
    motions_from_results,
)
from .two_groups import (
    CONTROLS,
    DEFAULT_ABNORMALITY,
    GROUPS_FILE,
    PATIENTS,
    REGION_FILE,
    TwoGroupCohort,
    make_two_group_cohort,
    write_two_group_cohort,
)

__all__ = [
    "OutcomeOutcome",
    "analyze_outcome",
    "outcome_arrays",
    "predict_outcome",
    "ModelOutcome",
    "analyze_model",
    "check_design_table",
    "ModelDesign",
    "groups_design",
    "model_design",
    "MODEL_TESTS",
    "ModelComparison",
    "compare_model",
    "model_responses",
    "AHA_NAMES",
    "aha_segments",
    "read_aha_landmarks",
    "SegmentTable",
    "segment_means",
    "segment_table",
    "NullRate",
    "TransportScore",
    "null_false_positive_rate",
    "score_transports",
    "scores_csv",
    "read_scores_csv",
    "scores_markdown",
    "AnalysisOutcome",
    "analyze",
    "check_groups_table",
    "read_planted_region",
    "select_motions",
    "write_analysis",
    "NORMALIZATIONS",
    "GroupComparison",
    "compare_groups",
    "normalize_motion",
    "NO_TRANSPORT",
    "StudyResults",
    "TransportedMotion",
    "load_study_results",
    "load_transported_motion",
    "motions_from_results",
    "CONTROLS",
    "DEFAULT_ABNORMALITY",
    "GROUPS_FILE",
    "PATIENTS",
    "REGION_FILE",
    "TwoGroupCohort",
    "make_two_group_cohort",
    "write_two_group_cohort",
    "CYCLE_ABNORMALITY",
    "CohortCycles",
    "make_two_group_cycles",
    "IMAGE_KINDS",
    "cycle_grid",
    "valve_planes",
    "cycle_valve_planes",
    "VALVE_PLANES_FILE",
    "write_cycle_cohort",
    "two_group_cycles",
    "covariate_cycles",
    "cohort_outcome",
    "regional_motion",
    "AnatomyShift",
    "CohortGroup",
    "CovariateCohort",
    "Covariates",
    "DESIGN_FILE",
    "make_covariate_cohort",
    "write_covariate_cohort",
    "MOTION_PARAMETERS",
    "ideal_transport",
    "ideal_cycle_transport",
    "transport_error",
]
