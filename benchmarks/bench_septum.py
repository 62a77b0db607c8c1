"""The septal direction from a right-ventricle label, with and without the wall's harmonics.

    python benchmarks/bench_septum.py              # prints the table
    python benchmarks/bench_septum.py --publish    # docs/generated/septum_harmonics.md

The 20 subjects of ``make_two_group_cohort(seed=3)`` (the orientation benchmark's),
once with the model's azimuthal wall harmonics and once without
(``SyntheticLVModel(harmonic_amplitude=0)``), unposed: each end-diastole voxelised on
1.5 mm voxels with the RV crescent of :func:`~ladders.study.imaging.add_rv_label`
centred on the true septum, meshed with the cut at the valve plane, and its
landmarks found by :func:`~ladders.study.imaging.landmarks_from_labels` with either
septal direction: the bisector of the RV's insertion points (the default) or the
direction toward the RV's centroid. The error is the angle to the true septal
direction (the landmark table's, degrees). Without harmonics the LV is a surface of
revolution and the crescent the same on both sides of the septum; the difference
between the two rows is what the harmonics do to each estimate.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import publishing_main  # noqa: E402

from ladders.study.cohort.synthetic_lv import SyntheticLVModel  # noqa: E402
from ladders.study.imaging import (  # noqa: E402
    LabelImage,
    MeshingSettings,
    add_rv_label,
    extract_surface,
    landmarks_from_labels,
    voxelize,
)
from ladders.study.population import make_two_group_cohort  # noqa: E402
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks  # noqa: E402

SPACING = 1.5
METHODS = ("insertion", "centroid")


def _angle(a, b) -> float:
    cosine = a @ b / np.linalg.norm(a) / np.linalg.norm(b)
    return float(np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0))))


def septum_errors(model: SyntheticLVModel | None, n: int = 20) -> np.ndarray:
    """Per subject and method (columns as :data:`METHODS`): the septal direction's error."""
    data = make_two_group_cohort(n_subjects=n, seed=3, model=model)
    rows = []
    for s in data.cohort.subjects:
        truth = synthetic_landmarks(s.ed)
        low = s.ed.min(axis=0) - 25.0
        shape = tuple(int(k) for k in np.ceil((s.ed.max(axis=0) + 25.0 - low) / SPACING))
        affine = np.diag([SPACING, SPACING, SPACING, 1.0])
        affine[:3, 3] = low
        top = np.array([0.0, 0.0, s.ed[:, 2].max()])
        labels = voxelize(s.ed, data.cohort.faces, affine, shape, label=1)
        labels = add_rv_label(labels, affine, truth.apex, top, truth.septum - truth.apex)
        image = LabelImage(labels.astype(np.int64), affine, Path(f"{s.name}_ed.nii.gz"))
        settings = MeshingSettings(cut_plane=(*top, 0.0, 0.0, 1.0))
        v, f, _ = extract_surface(image, 1, settings)
        rows.append([
            _angle(landmarks_from_labels(v, f, image, 2, cut_plane=settings.cut_plane,
                                         septum=m).septal_direction, truth.septal_direction)
            for m in METHODS
        ])  # fmt: skip
    return np.array(rows)


def table() -> str:
    lines = [
        "| end-diastoles, unposed, 1.5 mm voxels | bisector of the RV's insertion points "
        "(default) | toward the RV's centroid |",
        "|---|---|---|",
    ]
    for label, model in (("default model", None),
                         ("no wall harmonics", SyntheticLVModel(harmonic_amplitude=0.0))):  # fmt: skip
        e = septum_errors(model)
        cells = [f"{np.median(e[:, i]):.2f} / {e[:, i].max():.2f}" for i in range(len(METHODS))]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    note = (
        "The septal direction from the RV label against the true one, median / max over 20 "
        "subjects of `make_two_group_cohort(seed=3)` (degrees), with the model's azimuthal "
        "wall harmonics and without (`SyntheticLVModel(harmonic_amplitude=0)`)."
    )
    return note + "\n\n" + "\n".join(lines) + "\n"


if __name__ == "__main__":
    publishing_main("septum_harmonics", __doc__, table)
