"""The scaled-down ground truth shared by the Python-API and the command-line tests.

A small built-in cohort is written as segmentations (remeshed, moved rigidly,
one subject in metres); its study in the corresponded meshes' frame is the
reference (``docs/preparation.md``, "Ground truth"). The study's settings and
the tolerances on Table 1 live here once.
"""

import csv

import numpy as np

from ladders.study import StudyConfig, run_study
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from ladders.study.preparation import (
    icp_align,
    procrustes_aligned,
    simulate_segmentations,
    surface_distances,
)
from ladders.study.reporting import summarize

N_SUBJECTS, N_VERTICES, SEED = 3, 150, 0
IN_METRES = "synthetic_001"
ALPHA2 = (1.0, 1089.0)
SIGMA, MAX_ITER = 10.0, 1000  # the study's default kernel width; iteration limit here
#: The study's flags for these settings (``symladders study``).
STUDY_FLAGS = ["--sigma", str(SIGMA), "--max-iter", str(MAX_ITER),
               "--alpha2", ",".join(f"{a:g}" for a in ALPHA2)]  # fmt: skip

TABLE1 = [
    (a, v, m)
    for a in ALPHA2
    for v in ("residual", "no_residual")
    for m in ("centrality", "involutivity", "transvectivity")
] + [
    (a, "both", m)
    for a in ALPHA2
    for m in ("registration_error", "registration_norm", "inverse_consistency")
]


def simulated(folder):
    """``(cohort, motions)``: the cohort and its segmentations written into ``folder``, with
    their landmark table (the poses are any rotation: only landmarks fix the turn about the
    long axis then)."""
    cohort = make_synthetic_cohort(N_SUBJECTS, n_vertices=N_VERTICES, seed=SEED)
    motions = simulate_segmentations(
        cohort, folder, np.random.default_rng(SEED), in_metres=[IN_METRES], landmarks=True
    )
    return cohort, motions


def table(atlas, faces, subjects, folder) -> dict:
    """Table 1 (``{(alpha2, variant, measure): mean}``) of the study on ``subjects``."""
    config = StudyConfig.build(sigma=SIGMA, max_iter=MAX_ITER, alpha2=ALPHA2)
    res = run_study(config, atlas, faces, subjects, folder, jobs=1, progress=False, meshes=False)
    return {(r.alpha2, r.variant, r.measure): r.mean for r in summarize(res.results)}


def reference_table(cohort, folder) -> dict:
    """The study on the original meshes brought into the corresponded meshes' frame."""
    return table(cohort.atlas, cohort.faces, procrustes_aligned(cohort), folder)


def table_from_csv(path) -> dict:
    """Table 1 as :func:`table` gives it, from a study's ``summary.csv``."""
    with open(path, newline="") as fh:
        return {(float(r["alpha2"]), r["variant"], r["measure"]): float(r["mean"])
                for r in csv.DictReader(fh)}  # fmt: skip


def assert_reproduces_table_1(reference: dict, found: dict) -> None:
    """Every cell above 1e-3 mm within 10 % (the issue's target; 3 % was measured at
    these settings), and the paper's claims on both: (a) residuals lower centrality
    and involutivity; (b) the registration error rises and the norm falls with
    alpha^2."""
    rel = {k: found[k] / reference[k] - 1 for k in TABLE1 if reference[k] > 1e-3}
    assert len(rel) >= 14, rel
    assert all(abs(rel[k]) < 0.10 for k in rel), rel
    for t in (reference, found):
        for a in ALPHA2:
            for m in ("centrality", "involutivity"):
                assert t[(a, "residual", m)] < t[(a, "no_residual", m)]
        assert t[(1.0, "both", "registration_error")] < t[(1089.0, "both", "registration_error")]
        assert t[(1.0, "both", "registration_norm")] > t[(1089.0, "both", "registration_norm")]


def template_distance(vertices, faces, cohort, align: bool = False) -> float:
    """Mean surface distance of a mesh to the generating template, after ICP onto it
    when ``align`` (a mesh in an arbitrary frame)."""
    if align:
        vertices = icp_align(vertices, faces, cohort.atlas, cohort.faces)[0].apply(vertices)
    return surface_distances(vertices, faces, cohort.atlas, cohort.faces)["mean_surface_distance"]


def mean_subject_distance(cohort, align: bool = False) -> float:
    """The subjects' mean :func:`template_distance` (in the model's frame, or aligned)."""
    return float(np.mean([template_distance(s.ed, cohort.faces, cohort, align)
                          for s in cohort.subjects]))  # fmt: skip
