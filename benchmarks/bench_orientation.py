"""Segmentations against their ground truth: the orientation kept and the wall motion kept.

    python benchmarks/bench_orientation.py                 # 20 subjects, every condition
    python benchmarks/bench_orientation.py --subjects 6    # quicker
    python benchmarks/bench_orientation.py --publish       # docs/generated/orientation*.md

The two-group cohort (``make_two_group_cohort``, seed 3, default hypokinesia) is
written as segmentations (``write_two_group_cohort``: every mesh re-triangulated
with as many faces as the atlas, optionally each subject moved by a random rigid
motion of up to 30 degrees and 20 mm, optionally with the landmark table) and
brought back by ``correspond_cohort`` with its defaults. The truth is the
generator's: the material points of every vertex and each subject's pose.

Per condition and subject:

* the rotation left: the recorded transform composed with the pose (degrees;
  0 when the subject is brought back exactly into the atlas's frame), beside
  the pose's own twist about the long axis (which no surface fit can see) and the
  excess ``left - twist``;
* the end-diastolic vertex error: mean distance of the corresponded vertices to
  the true material points moved by the same transform (mm);
* the group difference (patients minus controls) in the planted region of the
  normal motion ``(ES - ED) . n`` (atlas normals) and of the ray-cast wall motion
  (:func:`~ladders.study.wall_motion.normal_wall_motion`), against the same on
  the generating meshes;
* the same rotation left for the rigid alignment of ``estimate_atlas`` (every
  subject's end-diastole onto the first one's, by ``fit_rigid`` as the atlas does).

The label-image route: the posed subjects voxelised (1.5 mm voxels,
the cavity as label 1, a right ventricle beside the septum as label 2,
:func:`~ladders.study.imaging.add_rv_label`), meshed by ``mesh_label_images`` with
``rv_label=2`` (the landmark table from the RV) and corresponded with it: with the
septal direction half way between the RV's insertion points (the default) and toward
the RV's centroid (``rv_septum="centroid"``).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.study.meshes import read_mesh  # noqa: E402
from ladders.study.population import make_two_group_cohort, write_two_group_cohort  # noqa: E402
from ladders.study.preparation import CorrespondenceSettings, correspond_cohort  # noqa: E402
from ladders.study.preparation.alignment import SimilarityTransform  # noqa: E402
from ladders.study.preparation.landmarks import read_landmarks  # noqa: E402
from ladders.study.preparation.rigid_fit import fit_rigid  # noqa: E402
from ladders.study.wall_motion import normal_wall_motion, outward_vertex_normals  # noqa: E402

#: (label, pose, landmarks, ES correspondence)
CONDITIONS = (
    ("remeshed, no pose", False, False, "normal"),
    ("remeshed, no pose, ES registered (former default)", False, False, "registration"),
    ("remeshed, posed up to 30 degrees, no landmarks", True, False, "normal"),
    ("remeshed, posed up to 30 degrees, landmark table", True, True, "normal"),
    ("label images (1.5 mm), posed up to 30 degrees, RV label", True, "images", "normal"),
    (
        "label images (1.5 mm), posed up to 30 degrees, RV label, septum toward its centroid",
        True,
        "images_centroid",
        "normal",
    ),
)


def twist_angle(rotation: np.ndarray, axis: np.ndarray) -> float:
    """Magnitude in degrees of the twist of ``rotation`` about ``axis`` (swing-twist split)."""
    x, y, z, w = Rotation.from_matrix(rotation).as_quat()
    p = np.dot([x, y, z], axis)
    angle = abs(np.degrees(2.0 * np.arctan2(p, w)))
    return float(min(angle, 360.0 - angle))


def _group_difference(values: np.ndarray, patients: np.ndarray, affected: np.ndarray) -> float:
    """Mean over the planted region of patients' mean minus controls' mean."""
    diff = values[patients].mean(axis=0) - values[~patients].mean(axis=0)
    return float(diff[affected].mean())


def _motion_measures(eds, ess, atlas, faces, patients, affected) -> tuple[float, float]:
    normals = outward_vertex_normals(atlas, faces)
    normal = np.einsum("nkj,kj->nk", ess - eds, normals)
    wall = np.stack([normal_wall_motion(e, faces, s, faces).distance for e, s in zip(eds, ess)])
    return _group_difference(normal, patients, affected), _group_difference(
        wall, patients, affected
    )


def run_condition(data, label, pose, landmarks, es, work: Path, jobs: int) -> dict:
    folder = work / "segmentations" / ("posed" if pose else "unposed")
    if not (folder / "landmarks.csv").is_file():
        write_two_group_cohort(data, folder, remesh_factor=1.0, pose=pose, landmarks=True)
    if landmarks == "images":
        folder = write_label_images(data, work)
    elif landmarks == "images_centroid":
        folder = write_label_images(data, work, septum="centroid", meshes="images_meshed_centroid")
    truth = json.loads((folder / "planted_region.json").read_text())
    poses = {n: SimilarityTransform.from_matrix(np.array(m)) for n, m in truth["poses"].items()}
    out = work / "corresponded" / label.replace(" ", "_").replace(",", "")
    settings = CorrespondenceSettings(es_correspondence=es)
    start = time.perf_counter()
    images = landmarks in ("images", "images_centroid")
    atlas = work / "segmentations" / "posed" / "atlas.vtk" if images else None
    result = correspond_cohort(atlas or folder / "atlas.vtk", folder, out, settings, jobs=jobs,
                               landmarks=None if landmarks else False)  # fmt: skip
    seconds = time.perf_counter() - start
    cohort = data.cohort
    atlas, faces = cohort.atlas, cohort.faces
    z = np.array([0.0, 0.0, 1.0])
    rows, eds, ess, true_ed, true_es, patients = [], [], [], [], [], []
    for s in cohort.subjects:
        record = json.loads((out / "correspondence" / f"{s.name}.json").read_text())
        if record["status"] != "ok":
            continue
        transform = SimilarityTransform.from_dict(record["transform"])
        left = transform.compose(poses[s.name])
        ed = read_mesh(out / f"{s.name}_ed.vtk")[0]
        es_v = read_mesh(out / f"{s.name}_es.vtk")[0]
        truth_ed = left.apply(s.ed)
        rows.append(
            {
                "left": left.rotation_angle(),
                "twist": twist_angle(poses[s.name].rotation.T, z),
                "ed_error": float(np.linalg.norm(ed - truth_ed, axis=1).mean()),
            }
        )
        eds.append(ed)
        ess.append(es_v)
        true_ed.append(s.ed)
        true_es.append(s.es)
        patients.append(data.groups[s.name] == "patients")
    patients = np.array(patients)
    affected = data.region.affected
    normal, wall = _motion_measures(np.array(eds), np.array(ess), atlas, faces, patients, affected)
    true_normal, true_wall = _motion_measures(
        np.array(true_ed), np.array(true_es), atlas, faces, patients, affected
    )
    left = np.array([r["left"] for r in rows])
    excess = np.array([r["left"] - r["twist"] for r in rows])
    err = np.array([r["ed_error"] for r in rows])
    return {
        "label": label, "n": len(rows), "failed": len(result.failed), "seconds": seconds,
        "left_median": float(np.median(left)), "left_max": float(left.max()),
        "excess_max": float(excess.max()), "twist_max": float(max(r["twist"] for r in rows)),
        "ed_error_median": float(np.median(err)), "ed_error_max": float(err.max()),
        "normal": normal, "true_normal": true_normal, "wall": wall, "true_wall": true_wall,
    }  # fmt: skip


def write_label_images(data, work: Path, spacing: float = 1.5, septum: str = "insertion",
                       meshes: str = "images_meshed") -> Path:  # fmt: skip
    """The posed segmentations' generating meshes as label images with an RV label, meshed
    into ``WORK/meshes`` with the septal direction taken by ``septum``."""
    from ladders.study.imaging import add_rv_label, mesh_label_images, voxelize, write_label_image
    from ladders.study.preparation.landmarks import write_landmarks
    from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks

    posed = work / "segmentations" / "posed"
    truth = json.loads((posed / "planted_region.json").read_text())
    images, meshes = work / "images", work / meshes
    planes = {}
    for s in data.cohort.subjects:
        pose = SimilarityTransform.from_matrix(np.array(truth["poses"][s.name]))
        lm = synthetic_landmarks(s.ed).transformed(pose)
        world_ed = pose.apply(s.ed)  # one grid for both frames, around end-diastole
        low = world_ed.min(axis=0) - 25.0
        shape = tuple(int(n) for n in np.ceil((world_ed.max(axis=0) + 25.0 - low) / spacing))
        affine = np.diag([spacing, spacing, spacing, 1.0])
        affine[:3, 3] = low
        for phase, v in (("ed", s.ed), ("es", s.es)):
            top = pose.apply(np.array([[0.0, 0.0, v[:, 2].max()]]))[0]
            name = f"{s.name}_{phase}.nii.gz"
            planes[name] = (*top, *(pose.rotation @ [0.0, 0.0, 1.0]))
            if (images / name).is_file():  # written by an earlier run
                continue
            labels = voxelize(pose.apply(v), data.cohort.faces, affine, shape, label=1)
            labels = add_rv_label(labels, affine, lm.apex, top, lm.septum - lm.apex)
            write_label_image(images / name, labels, affine)
    # meshes made before with the same settings are reused (their provenance records)
    mesh_label_images(sorted(images.iterdir()), 1, meshes, cut_planes=planes, progress=False,
                      rv_label=2, rv_septum=septum)  # fmt: skip
    table = read_landmarks(meshes / "landmarks.csv")
    write_landmarks(meshes / "landmarks.csv", {"atlas": synthetic_landmarks(data.cohort.atlas),
                                               **table})  # fmt: skip
    (meshes / "planted_region.json").write_text(json.dumps(truth))
    return meshes


def run_atlas_alignment(data, work: Path, landmarks: bool) -> dict:
    """The rigid alignment ``estimate_atlas`` makes on the posed cohort: every subject's
    end-diastole onto the first one's (the start), by ``fit_rigid`` with its settings."""
    folder = work / "segmentations" / "posed"
    truth = json.loads((folder / "planted_region.json").read_text())
    names = [s.name for s in data.cohort.subjects]
    poses = [SimilarityTransform.from_matrix(np.array(truth["poses"][n])) for n in names]
    meshes = [read_mesh(folder / f"{n}_ed.vtk") for n in names]
    table = read_landmarks(folder / "landmarks.csv") if landmarks else None
    tolerance = CorrespondenceSettings().rotation_tolerance
    axis = poses[0].rotation @ np.array([0.0, 0.0, 1.0])
    left, excess = [], []
    for name, (v, f), pose in zip(names[1:], meshes[1:], poses[1:]):
        lm = {} if table is None else {"source_landmarks": table[name],
                                       "target_landmarks": table[names[0]]}  # fmt: skip
        transform = fit_rigid(v, f, *meshes[0], tolerance=tolerance, **lm).transform
        true = poses[0].compose(pose.inverse())
        rest = transform.compose(true.inverse())
        left.append(rest.rotation_angle())
        excess.append(rest.rotation_angle() - twist_angle(true.rotation, axis))
    label = "atlas alignment, posed, " + ("landmark table" if landmarks else "no landmarks")
    return {"label": label, "left_median": float(np.median(left)), "left_max": float(max(left)),
            "excess_max": float(max(excess))}  # fmt: skip


def _table(rows: list[dict], atlas_rows: list[dict]) -> str:
    lines = [
        "| condition | rotation left, median / max (deg) | left minus the pose's twist, max (deg) "
        "| ED vertex error, median / max (mm) | (ES - ED) . n, group difference (mm) "
        "| ray-cast wall motion, group difference (mm) |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['label']} ({r['n']} subjects, {r['failed']} failed) | {r['left_median']:.1f} / "
            f"{r['left_max']:.1f} | {r['excess_max']:.1f} | {r['ed_error_median']:.2f} / "
            f"{r['ed_error_max']:.2f} | {r['normal']:.2f} (true {r['true_normal']:.2f}, "
            f"{r['normal'] / r['true_normal'] - 1:+.0%}) | {r['wall']:.2f} (true "
            f"{r['true_wall']:.2f}, {r['wall'] / r['true_wall'] - 1:+.0%}) |"
        )
    for r in atlas_rows:
        lines.append(
            f"| {r['label']} | {r['left_median']:.1f} / {r['left_max']:.1f} | "
            f"{r['excess_max']:.1f} | - | - | - |"
        )
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--subjects", type=int, default=20)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--work", type=Path, default=None)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    data = make_two_group_cohort(n_subjects=args.subjects, seed=3)
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        rows = []
        for label, pose, landmarks, es in CONDITIONS:
            rows.append(run_condition(data, label, pose, landmarks, es, work, args.jobs))
            print(_table(rows[-1:], []), flush=True)
        atlas_rows = [run_atlas_alignment(data, work, lm) for lm in (False, True)]
    table = _table(rows, atlas_rows)
    print(table)
    if args.publish:
        note = (
            f"{args.subjects} subjects of `make_two_group_cohort(seed=3)` (default hypokinesia, "
            f"{int(data.labels.sum())} patients), every mesh re-triangulated "
            "(`write_two_group_cohort(remesh_factor=1.0)`), `correspond_cohort` with its "
            "defaults; the truth is the generator's material points and poses."
        )
        publish("orientation", f"{note}\n\n{table}", "python benchmarks/bench_orientation.py")


if __name__ == "__main__":
    main()
