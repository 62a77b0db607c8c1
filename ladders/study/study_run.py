"""The study in one call: :func:`run`, what ``symladders study`` runs for one deformation model.

``run(StudyConfig(...), cohort, output)`` checks the configuration against the
cohort before any registration (a kernel width in another unit than the meshes,
:func:`~ladders.study.running.preflight.check_sigma`; the deformation model's
interface on the atlas, :func:`~ladders.study.deformations.check_deformation_model`;
every field of :class:`~ladders.study.running.pipeline.StudyConfig` is checked when
it is built),
runs or resumes the study (:func:`~ladders.study.running.runner.run_study`) and
writes its report (:func:`~ladders.study.reporting.write_report`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from .cohort import Cohort, make_synthetic_cohort
from .deformations import check_deformation_model
from .reporting import write_report
from .running import StudyConfig, run_study
from .running.preflight import check_sigma
from .running.runner import StudyOutcome

__all__ = ["StudyRun", "run", "DEFAULT_OUTPUT", "DEFAULT_SUBJECTS"]

#: Where the study writes when no folder is given.
DEFAULT_OUTPUT = "symladders-output/study"
#: Subjects of the built-in cohort in the default study.
DEFAULT_SUBJECTS = 20


@dataclass
class StudyRun:
    """What :func:`run` returns: the runner's outcome and the report's files."""

    outcome: StudyOutcome
    report: dict = field(default_factory=dict)


def run(
    config: StudyConfig | None = None,
    cohort: Cohort | None = None,
    output=DEFAULT_OUTPUT,
    *,
    jobs: int = 2,
    progress: bool = True,
    meshes: bool = True,
    report: bool = True,
    units: str | None = None,
    data_description: dict | None = None,
    input_files: list | None = None,
) -> StudyRun:
    """Run (or resume) the study of ``cohort`` with ``config`` into ``output``, and report it.

    Parameters
    ----------
    config : StudyConfig, optional
        Default ``StudyConfig()``: the default settings and ``alpha^2`` sweep.
    cohort : Cohort, optional
        Default: the first :data:`DEFAULT_SUBJECTS` subjects of the built-in cohort.
    output : path
    jobs, progress, meshes, data_description, input_files
        See :func:`~ladders.study.running.runner.run_study`.
    report : bool, default True
        Write the tables and figures (:func:`~ladders.study.reporting.write_report`).
    units : str, optional
        How the meshes' units were obtained, stated under Table 1.

    Returns
    -------
    StudyRun

    Raises
    ------
    manifolds.errors.ManifoldError
        The kernel width cannot be in the meshes' unit (before any registration).
    ladders.study.deformations.DeformationModelError
        The deformation model breaks the interface (one line naming it and the property).
    """
    config = StudyConfig() if config is None else config
    cohort = make_synthetic_cohort(DEFAULT_SUBJECTS) if cohort is None else cohort
    check_sigma(cohort.atlas, config.registration)
    check_deformation_model(config.model, cohort.atlas, config.registration)
    output = Path(output)
    outcome = run_study(
        config, cohort.atlas, cohort.faces, cohort.subjects, output, jobs=jobs,
        progress=progress, data_description=data_description, meshes=meshes,
        input_files=input_files,
    )  # fmt: skip
    paths = {}
    if report:
        shapes = {s.name: s.ed for s in cohort.subjects}
        rule = config.registration.stopping_rule()
        paths = write_report(outcome.results, output, cohort.atlas, cohort.faces, shapes,
                             stopping=rule.describe(), units=units)  # fmt: skip
    return StudyRun(outcome, paths)
