"""One route from a subjects table to the adjusted maps: ``symladders run SETTINGS``.

A study is described once, by a subjects table (:mod:`.subjects_table`) and a small
settings file (:mod:`.route_settings`); the route (:mod:`.route_plan`) is the
sequence of ``symladders`` commands that takes the images to the model's maps, run
and reused step by step (:mod:`.route_runner`), and summed up in ``report.md``
(:mod:`.route_report`).
"""

from .fingerprint import Fingerprints
from .route_inputs import RouteInputs, write_route_inputs
from .route_model import RouteModel, formula_columns, route_model
from .route_plan import STEP_NAMES, Step, plan_route
from .route_report import left_out_subjects, subjects_with_results, truth_scores, write_report
from .route_runner import RECORD_FILE, RouteError, RouteOutcome, StepOutcome, load_route, run_route
from .route_settings import (
    SETTINGS,
    RouteSettings,
    RouteSettingsError,
    read_route_settings,
    settings_template,
)
from .subjects_table import (
    FRAME_COLUMNS,
    IMAGE_COLUMNS,
    SubjectEntry,
    SubjectsTable,
    SubjectsTableError,
    read_subjects_table,
)

__all__ = [
    "Fingerprints",
    "RouteInputs",
    "write_route_inputs",
    "RouteModel",
    "formula_columns",
    "route_model",
    "STEP_NAMES",
    "Step",
    "plan_route",
    "left_out_subjects",
    "truth_scores",
    "subjects_with_results",
    "write_report",
    "RECORD_FILE",
    "RouteError",
    "RouteOutcome",
    "StepOutcome",
    "load_route",
    "run_route",
    "SETTINGS",
    "RouteSettings",
    "RouteSettingsError",
    "read_route_settings",
    "settings_template",
    "FRAME_COLUMNS",
    "IMAGE_COLUMNS",
    "SubjectEntry",
    "SubjectsTable",
    "SubjectsTableError",
    "read_subjects_table",
]
