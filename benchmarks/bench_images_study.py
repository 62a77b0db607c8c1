"""The study from label images beside the study from the meshes the images were made of.

    python benchmarks/bench_images_study.py [--subjects 10] [--work DIR] [--jobs 2]

The first subjects of the built-in cohort, four ways into the study (default settings,
``alpha^2`` in 0.01, 0.1, 1, 100 and 1089):

* ``meshes``: the cohort's meshes as generated (in correspondence, in the model's frame);
* ``meshes, corresponded``: the same meshes through ``correspond_cohort`` (rigid
  alignment to the atlas, then the atlas registered onto each mesh): what the
  correspondence step alone changes;
* ``images iso 1 mm`` and ``images SAX 1.5 x 1.5 x 8 mm``: each subject's ED and ES
  cavities voxelised exactly on one grid per subject, written as NIfTI, meshed by
  ``mesh_label_images`` (default settings, cut at the valve plane), then corresponded as
  above: the documented chain from label images.

Printed and written to ``docs/generated/images_study.md``: Table 1's cells (means over
subjects, per-vertex RMS mm) per arm with the relative change against ``meshes,
corresponded`` for the image arms, and the paper's claims (a) (residuals lower the
midpoint distance, centrality and involutivity, at each ``alpha^2``) and (b) (the
registration error rises and the deformation norm falls with ``alpha^2``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_images import ACQUISITIONS, _grid  # noqa: E402
from bench_sensitivity import ALPHA2, ERRORS, summarise  # noqa: E402
from generated_tables import machine, publish  # noqa: E402

from ladders.study import StudyConfig, make_synthetic_cohort, read_cohort, run, write_mesh  # noqa: E402
from ladders.study.imaging import mesh_label_images, voxelize, write_label_image  # noqa: E402
from ladders.study.preparation import correspond_cohort  # noqa: E402

IMAGE_ARMS = {"images iso 1 mm": "iso 1 mm", "images SAX 1.5 x 1.5 x 8 mm": "SAX 1.5 x 1.5 x 8 mm"}
ARMS = ("meshes", "meshes, corresponded", *IMAGE_ARMS)
#: Table 1's cells: (measure, variant).
CELLS = (
    ("midpoint_distance", "residual"),
    ("midpoint_distance", "no_residual"),
    ("centrality", "residual"),
    ("centrality", "no_residual"),
    ("involutivity", "residual"),
    ("involutivity", "no_residual"),
    ("transvectivity", "residual"),
    ("transvectivity", "no_residual"),
)


def _slug(arm: str) -> str:
    return "".join(c if c.isalnum() else "_" for c in arm).strip("_")


def _label_images(cohort, acquisition: str, folder: Path) -> dict:
    """One NIfTI file per subject and frame, both frames of a subject on one grid."""
    in_plane, thickness, tilt, flip = ACQUISITIONS[acquisition]
    planes = {}
    folder.mkdir(parents=True, exist_ok=True)
    for s in cohort.subjects:
        affine, shape = _grid(np.vstack([s.ed, s.es]), in_plane, thickness, tilt, flip)
        for phase in ("ed", "es"):
            vertices = getattr(s, phase)
            name = f"{s.name}_{phase}.nii.gz"
            if not (folder / name).is_file():
                labels = voxelize(vertices, cohort.faces, affine, shape, label=1)
                write_label_image(folder / name, labels, affine)
            planes[name] = (0.0, 0.0, float(vertices[:, 2].max()), 0.0, 0.0, 1.0)
    return planes


def arm_cohort(arm: str, cohort, work: Path, jobs: int):
    """The cohort the study of ``arm`` runs on (see the module)."""
    if arm == "meshes":
        return cohort
    folder = work / _slug(arm)
    atlas = folder / "atlas.vtk"
    folder.mkdir(parents=True, exist_ok=True)
    write_mesh(atlas, cohort.atlas, cohort.faces)
    start = time.perf_counter()
    if arm == "meshes, corresponded":
        meshes = folder / "meshes"
        meshes.mkdir(exist_ok=True)
        for s in cohort.subjects:
            for phase in ("ed", "es"):
                write_mesh(meshes / f"{s.name}_{phase}.vtk", getattr(s, phase), cohort.faces)
    else:
        planes = _label_images(cohort, IMAGE_ARMS[arm], folder / "images")
        outcome = mesh_label_images(sorted((folder / "images").glob("*.nii.gz")), label=1,
                                    output=folder / "meshes", cut_planes=planes, jobs=jobs,
                                    progress=False)  # fmt: skip
        if outcome.failed:
            raise RuntimeError(f"{arm}: meshing failed: {outcome.failed}")
    corresponded = correspond_cohort(atlas, folder / "meshes", folder / "corresponded", jobs=jobs)
    if corresponded.failed:
        print(f"  {arm}: correspondence failed for {corresponded.failed}", flush=True)
    print(f"  {arm}: meshes and correspondence {time.perf_counter() - start:.0f} s", flush=True)
    return read_cohort(folder / "corresponded")


def _fmt(x: float) -> str:
    return f"{x:.3g}"


def table(summaries: dict) -> str:
    arms = list(summaries)
    ref = summaries.get("meshes, corresponded")
    lines = ["| measure | variant | α² | " + " | ".join(arms) + " |",
             "|---|---|---|" + "---:|" * len(arms)]  # fmt: skip
    for measure, variant in CELLS:
        for a2 in ALPHA2:
            cells = []
            for arm in arms:
                value = summaries[arm]["means"][str(a2)][variant][measure]
                text = _fmt(value)
                if ref is not None and arm in IMAGE_ARMS:
                    base = ref["means"][str(a2)][variant][measure]
                    text += f" ({100 * (value / base - 1):+.0f} %)"
                cells.append(text)
            lines.append(f"| {measure} | {variant} | {a2:g} | " + " | ".join(cells) + " |")
    for name, key in (("registration error", "registration_error"), ("norm", "rkhs_norm")):
        for i, a2 in enumerate(ALPHA2):
            cells = []
            for arm in arms:
                value = summaries[arm][key][i]
                text = _fmt(value)
                if ref is not None and arm in IMAGE_ARMS:
                    text += f" ({100 * (value / ref[key][i] - 1):+.0f} %)"
                cells.append(text)
            lines.append(f"| {name} | both | {a2:g} | " + " | ".join(cells) + " |")
    lines += ["", "| claim of the paper | " + " | ".join(arms) + " |",
              "|---|" + "---|" * len(arms)]  # fmt: skip
    claim_a = []
    for arm in arms:
        held = [all(s) for s in zip(*summaries[arm]["claim_a"].values())]
        claim_a.append(f"{sum(held)} of {len(held)} α² (all three errors)")
    lines.append("| (a) residuals lower midpoint distance, centrality, involutivity | "
                 + " | ".join(claim_a) + " |")  # fmt: skip
    lines.append("| (b) registration error rises, norm falls with α² | "
                 + " | ".join("yes" if summaries[a]["claim_b"] else "no" for a in arms) + " |")  # fmt: skip
    return "\n".join(lines)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=Path("symladders-output/bench_images_study"))
    parser.add_argument("--subjects", type=int, default=10)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--arms", nargs="+", choices=ARMS, default=list(ARMS))
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    cohort = make_synthetic_cohort(args.subjects)
    config = StudyConfig.build(alpha2=ALPHA2)
    summaries = {}
    for arm in args.arms:
        data = arm_cohort(arm, cohort, args.work, args.jobs)
        start = time.perf_counter()
        outcome = run(config, data, args.work / _slug(arm) / "study", jobs=args.jobs,
                      progress=False, meshes=False).outcome  # fmt: skip
        summaries[arm] = summarise(arm, outcome.results, time.perf_counter() - start)
        print(f"  {arm}: study {summaries[arm]['seconds']:.0f} s, "
              f"{len(outcome.failures)} failed", flush=True)  # fmt: skip
    text = table(summaries)
    print(text)
    note = (
        f"{args.subjects} subjects of the built-in cohort, default study settings; means over "
        "subjects, per-vertex RMS mm (norm: RKHS norm); in brackets, the change against the "
        "same meshes through the correspondence step. Errors measured: " + ", ".join(ERRORS) + "."
    )
    publish("images_study", f"{note}\n\n{text}", "python benchmarks/bench_images_study.py")


if __name__ == "__main__":
    main()
