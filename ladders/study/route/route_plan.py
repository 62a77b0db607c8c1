"""The steps of ``symladders run``: each one a ``symladders`` command, its folder and its inputs.

:func:`plan_route` turns a subjects table and its settings into the route, in order:

==================  ======================================================  ==============
step                command                                                 folder
==================  ======================================================  ==============
``mesh``            ``symladders mesh`` of every image (ED and ES)         ``meshes/``
``atlas``           ``symladders atlas`` of the ED meshes (a subset)       ``atlas/``
``correspond``      ``symladders correspond``: the atlas on every subject  ``corresponded/``
``track``           ``symladders track`` through the series (if any)      ``tracked/``
``study``           ``symladders study`` at one alpha^2: the transport     ``study/``
``analysis``        ``symladders analyze`` with the table's model          ``analysis/``
``cycle-study``     ``symladders cycle-study`` of the tracked subjects     ``cycle_study/``
``cycle-analysis``  ``symladders cycle-analyze`` with the model            ``cycle_analysis/``
``wall``            ``symladders wall``: thickness and strain (myocardium)  ``wall/``
``wall-analysis``   ``symladders cycle-analyze --measure thickening``       ``wall_analysis/``
``report``          ``report.md``: the entry point to the results          ``.``
==================  ======================================================  ==============

Every step is the command a user would type (printed by ``symladders run --dry-run``),
run through the same parser and functions: the route adds no second implementation,
only the inputs each command reads (:mod:`.route_inputs`) and the design of the
subjects that reached the analysis.
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass, field
from pathlib import Path

from .route_inputs import RouteInputs
from .route_model import RouteModel
from .subjects_table import SubjectsTable

__all__ = ["Step", "plan_route", "STEP_NAMES"]

STEP_NAMES = ("mesh", "atlas", "correspond", "track", "study", "analysis", "cycle-study",
              "cycle-analysis", "wall", "wall-analysis", "report")  # fmt: skip


@dataclass
class Step:
    """One step of the route.

    Attributes
    ----------
    name : str
        One of :data:`STEP_NAMES`.
    program : str or None
        The ``symladders`` subcommand (None: the report, written here).
    argv : list of str or None
        The ``symladders`` command's arguments (None: the report, written here).
    reads : list of Path
        Files and folders whose fingerprint decides whether the step is reused.
    writes : list of Path
        Its output folder (or files).
    display : list of str
        The command as printed (a glob in place of the image list).
    why : str
        What the step does, in one line.
    design : Path or None
        The design table written before the step (the subjects that reached it).
    design_from : Path or None
        The folder whose subjects the design keeps.
    """

    name: str
    program: str | None
    argv: list | None
    reads: list
    writes: list
    display: list = field(default_factory=list)
    why: str = ""
    design: Path | None = None
    design_from: Path | None = None

    def command(self, root: Path) -> str:
        """The command line, paths relative to ``root`` where they lie below it."""
        words = self.display or self.argv or []
        out = []
        for word in words:
            if isinstance(word, Path):
                try:
                    word = word.relative_to(root).as_posix()
                except ValueError:
                    word = str(word)
            out.append(shlex.quote(str(word)) if "*" not in str(word) else str(word))
        if self.program is None:
            return "(written by symladders run)"
        return " ".join(["symladders", self.program, *out])


def _execution(settings, batch: bool = True) -> list:
    e = settings["execution"]
    argv = ["--jobs", str(e["jobs"])] if batch else []
    if batch and e["backend"] == "dask":
        argv += ["--backend", "dask"]
    return argv + ["--no-progress"]


def plan_route(table: SubjectsTable, settings, model: RouteModel, inputs: RouteInputs,
               scheduler: str | None = None) -> list[Step]:  # fmt: skip
    """The steps of the route (see the module), in order.

    ``scheduler``: the Dask scheduler's address given to every batch step.
    """
    out = Path(settings.output)
    images = settings["images"]
    model_settings = settings["model"]
    alpha2 = f"{settings['transport']['alpha2']:g}"
    batch = _execution(settings)
    if scheduler is not None:
        batch += ["--scheduler", scheduler]
    steps = []
    meshes, atlas_dir = out / "meshes", out / "atlas"
    atlas = atlas_dir / "atlas.vtk"
    corresponded = out / "corresponded"
    files = inputs.image_paths(table)
    argv = [*files, "--label", str(images["label"]), "--vertices", str(images["vertices"])]
    if images["rv_label"] is not None:
        argv += ["--rv-label", str(images["rv_label"])]
    frames = any(e.ed_frame is not None or e.es_frame is not None for e in table.entries)
    if frames:
        argv += ["--frames", inputs.frames]
    if images["valve_planes"] is not None:
        argv += ["--cut-planes", inputs.planes]
    argv += ["-o", meshes, *batch]
    display = [inputs.images / "*", *argv[len(files) :]]
    given = [p for p, use in ((inputs.frames, frames), (inputs.planes, images["valve_planes"]))
             if use]  # fmt: skip
    steps.append(Step("mesh", "mesh", argv, [inputs.images, *given],
                      [meshes], display, "the surface of every image, ED and ES (world mm)"))  # fmt: skip
    landmarks = ["--landmarks", inputs.landmarks] if table.has_landmarks else []
    # the atlas keeps its line per iteration: the long step's progress, in its log
    argv = ["--meshes", meshes, "-o", atlas, *landmarks, "--max-iter",
            str(settings["atlas"]["max_iter"]), "--subset", str(settings["atlas"]["subset"]),
            *[a for a in batch if a != "--no-progress"]]  # fmt: skip
    steps.append(Step("atlas", "atlas", argv, [meshes, *landmarks[1:]], [atlas_dir], [],
                      "the mean ED shape of the subjects"))  # fmt: skip
    argv = ["--atlas", atlas, "--meshes", meshes, "-o", corresponded, *landmarks, *batch]
    steps.append(Step("correspond", "correspond", argv, [atlas_dir, meshes], [corresponded], [],
                      "the atlas's vertices on every subject's ED and ES"))  # fmt: skip
    tracked = out / "tracked"
    track = settings["tracking"]["track"] and bool(table.tracked)
    if track:
        argv = [inputs.tracked_meshes, inputs.series, "--label", str(images["label"])]
        if images["myocardium_label"] is not None:
            argv += ["--myocardium-label", str(images["myocardium_label"])]
        argv += ["-o", tracked, *batch]
        steps.append(Step("track", "track", argv, [inputs.tracked_meshes, inputs.series],
                          [tracked], [],
                          f"{len(table.tracked)} subject(s) followed through their series"))  # fmt: skip
    study = out / "study"
    model_argv = ["--deformation", settings["transport"]["deformation"]]
    for plugin in settings["transport"]["plugins"]:
        model_argv += ["--plugin", plugin]
    argv = ["--meshes", corresponded, "--alpha2", alpha2, *model_argv, "--no-meshes", "-o", study,
            *batch]  # fmt: skip
    steps.append(Step("study", "study", argv, [corresponded], [study], [],
                      f"every subject's ED-ES motion transported to the atlas (alpha^2 {alpha2})"))  # fmt: skip
    aha = atlas_dir / "atlas_landmarks.csv"
    has_landmarks = images["rv_label"] is not None or table.has_landmarks
    if model.formula is not None:
        analysis = out / "analysis"
        design = analysis / "design.csv"
        argv = [study, *_model_argv(model, model_settings, design)]
        if has_landmarks:
            argv += ["--aha", aha]
        argv += ["--transport", "pole_ladder_residual", "none", "-o", analysis,
                 *_execution(settings, batch=False)]  # fmt: skip
        steps.append(Step("analysis", "analyze", argv, [study, atlas_dir], [analysis], [],
                          f"the model '{model.formula}' at every atlas vertex",
                          design=design, design_from=study))  # fmt: skip
    if track:
        cycle = out / "cycle_study"
        argv = [tracked, "--atlas", corresponded / "atlas.vtk", "--alpha2", alpha2, *model_argv,
                "-o", cycle, *batch]  # fmt: skip
        steps.append(Step("cycle-study", "cycle-study", argv, [tracked, corresponded], [cycle], [],
                          "every tracked frame transported to the atlas"))  # fmt: skip
        if model.formula is not None and _comparable(table, model):
            cycle_analysis = out / "cycle_analysis"
            design = cycle_analysis / "design.csv"
            argv = [cycle, *_model_argv(model, model_settings, design)]
            if has_landmarks:
                argv += ["--aha", aha]
            argv += ["-o", cycle_analysis, *_execution(settings, batch=False)]
            steps.append(Step("cycle-analysis", "cycle-analyze", argv, [cycle, atlas_dir],
                              [cycle_analysis], [], f"the model '{model.formula}' over the whole "
                              "cycle (per frame, peak, time to peak, trajectory)",
                              design=design, design_from=cycle))  # fmt: skip
        if images["myocardium_label"] is not None and has_landmarks:
            wall = out / "wall"
            argv = [tracked, "--atlas", corresponded / "atlas.vtk", "--aha", aha, "-o", wall,
                    *batch]  # fmt: skip
            steps.append(Step("wall", "wall", argv, [tracked, corresponded, atlas_dir], [wall], [],
                              "wall thickness, thickening and strain of the tracked subjects"))  # fmt: skip
            if model.formula is not None and _comparable(table, model):
                wall_analysis = out / "wall_analysis"
                design = wall_analysis / "design.csv"
                argv = [wall, *_model_argv(model, model_settings, design), "--measure",
                        "thickening", "--aha", aha, "-o", wall_analysis,
                        *_execution(settings, batch=False)]  # fmt: skip
                steps.append(Step("wall-analysis", "cycle-analyze", argv, [wall, atlas_dir],
                                  [wall_analysis], [], f"the model '{model.formula}' on the wall's "
                                  "thickening over the cycle", design=design, design_from=wall))  # fmt: skip
    steps.append(Step("report", None, None, [s.writes[0] for s in steps], [out / "report.md"], [],
                      "report.md: the results, the flagged subjects, every setting"))  # fmt: skip
    return steps


def _model_argv(model: RouteModel, s: dict, design: Path) -> list:
    argv = ["--design", design, "--model", model.formula, "--contrast", *model.contrasts,
            "--permutations", str(s["permutations"]), "--alpha", f"{s['alpha']:g}",
            "--seed", str(s["seed"])]  # fmt: skip
    if s["tfce"]:
        argv.append("--tfce")
    if s["fwhm"] is not None:
        argv += ["--fwhm", f"{s['fwhm']:g}"]
    if s["blocks"] is not None:
        argv += ["--blocks", s["blocks"]]
    if s["outcome"] is not None:
        argv += ["--outcome", ",".join(s["outcome"])]
    return argv


#: The fewest tracked subjects per group for the cycle's analysis.
MIN_PER_GROUP = 3


def _comparable(table: SubjectsTable, model: RouteModel) -> bool:
    """Whether the tracked subjects make groups the cycle's analysis can compare (at least
    :data:`MIN_PER_GROUP` in each of two groups or more; without groups, at least
    :data:`MIN_PER_GROUP` more subjects than the model's columns)."""
    if len(model.groups) < 2:
        return len(table.tracked) >= len(model.columns) + 1 + MIN_PER_GROUP
    counts = [sum(e.covariates["group"] == g for e in table.tracked) for g in model.groups]
    return sum(c >= MIN_PER_GROUP for c in counts) >= 2
