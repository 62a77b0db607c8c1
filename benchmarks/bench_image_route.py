"""Where the label-image route's end-diastolic vertex error comes from, against the truth.

    python benchmarks/bench_image_route.py --work WORK    # WORK of bench_orientation.py --work
    python benchmarks/bench_image_route.py --work WORK --publish

Needs the work folder of ``bench_orientation.py`` (its label images meshed with the
RV label and corresponded). Per subject, against the generator's truth:

* the meshing: mean distance of the meshed end-diastole to the true (posed) surface,
  and its signed mean (outward positive: a mesh inside or outside the truth);
* the septal direction from the RV label against the true one (degrees);
* the corresponded end-diastole: mean vertex error to the true material points, its
  part along the true normals, the mean distance of the vertices to the true surface,
  and the rotation left;
* the same correspondence with the true landmark table instead of the RV-derived one
  (run here on the same image meshes, cached in ``WORK``): what the septum explains;
* the same images meshed with the lid removed by its normals instead of the cut half
  a voxel below the valve plane (``MeshingSettings(cut_margin=0, lid_angle=45)``,
  cached in ``WORK``), with the RV landmarks: what the strip of wall the default cut
  removes at the base explains. The row "rim below the true base" is the mean height
  of the meshed rim under the true valve plane;
* both: the lid removed by its normals and the true landmark table (cached in ``WORK``);
* the ED vertex error against the correspondence's regularisation weight alpha^2, on
  the image meshes and on the true surfaces (cached in ``WORK``);
* the same against the landmarks' anchoring of the affine fit: none, the apex's and
  base-plane centre's heights along the long axis (the default), the whole points;
* the RV route's base-plane centre against the true one, along the long axis and
  aside of it (the landmark table's base is the model's axis point; the RV route's,
  the centre of the meshed rim's section, on the valve plane);
* per subject, the ED vertex error of each column minus the same subject's on its true
  surface (remeshed, with the landmark table: the orientation benchmark's row);
* the septal direction from the RV label measured about the true long axis (the
  direction from the true axis line to the RV's centroid): whether a better axis
  would give a better septum, or the RV label itself sets the error.

The error along the wall is split about the long axis: its mean over the vertices (a
turn of the whole mesh, which the septal direction sets) and the mean deviation from
that turn (a pattern around the ventricle). A second table measures the floor of the
correspondence itself: on the true, unposed ED surfaces, with the model's azimuthal
wall harmonics and without them. The generator keeps each material point's angle
about the long axis when a harmonic bends the wall; a smooth deformation after an
affine fit carries the harmonic partly as a stretch along the wall instead.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import numpy as np
import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parent))

from generated_tables import machine, publish  # noqa: E402

from ladders.study.cohort.synthetic_lv import SyntheticLVModel  # noqa: E402
from ladders.study.imaging import label_centroid, read_label_image  # noqa: E402
from ladders.study.meshes import read_mesh  # noqa: E402
from ladders.study.population import make_two_group_cohort  # noqa: E402
from ladders.study.preparation import CorrespondenceSettings, correspond_cohort  # noqa: E402
from ladders.study.preparation.alignment import SimilarityTransform  # noqa: E402
from ladders.study.preparation.correspondence import correspond_mesh  # noqa: E402
from ladders.study.preparation.landmarks import read_landmarks, write_landmarks  # noqa: E402
from ladders.study.preparation.remeshing import remesh  # noqa: E402
from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks  # noqa: E402
from ladders.study.wall_motion import outward_vertex_normals  # noqa: E402

IMAGES = "label_images_(1.5_mm)_posed_up_to_30_degrees_RV_label"
CENTROID = IMAGES + "_septum_toward_its_centroid"
TRUE_SURFACES = "remeshed_posed_up_to_30_degrees_landmark_table"


def _distance(vertices, faces, points, signed: bool = False) -> np.ndarray:
    """Distances of ``points`` to the surface; ``signed``: outward positive."""
    surface = trimesh.Trimesh(vertices, faces, process=False)
    d = -trimesh.proximity.signed_distance(surface, points)  # trimesh: inside positive
    return d if signed else np.abs(d)


def _errors(data, poses, out: Path) -> np.ndarray:
    """Per subject: vertex error, its normal part, distance to the true surface, rotation left,
    the mean signed error along the long axis over the basal fifth of the vertices, and the
    error about the long axis: its mean (a turn) and the mean deviation from it."""
    faces = data.cohort.faces
    basal = data.cohort.atlas[:, 2] >= np.quantile(data.cohort.atlas[:, 2], 0.8)
    rows = []
    for s in data.cohort.subjects:
        record = json.loads((out / "correspondence" / f"{s.name}.json").read_text())
        left = SimilarityTransform.from_dict(record["transform"]).compose(poses[s.name])
        true = left.apply(s.ed)
        ed = read_mesh(out / f"{s.name}_ed.vtk")[0]
        normals = outward_vertex_normals(true, faces)
        axis = left.rotation @ np.array([0.0, 0.0, 1.0])  # apex to base, in the output frame
        around = np.cross(axis, normals)  # along the wall, about the long axis
        around /= np.maximum(np.linalg.norm(around, axis=1, keepdims=True), 1e-12)
        turn = np.einsum("kd,kd->k", ed - true, around)
        rows.append((
            np.linalg.norm(ed - true, axis=1).mean(),
            np.abs(np.einsum("kd,kd->k", ed - true, normals)).mean(),
            _distance(true, faces, ed).mean(),
            left.rotation_angle(),
            ((ed - true)[basal] @ axis).mean(),
            abs(turn.mean()),
            np.abs(turn - turn.mean()).mean(),
        ))  # fmt: skip
    return np.array(rows)


def _true_landmarks(data, poses, work: Path, jobs: int, meshes: str = "images_meshed",
                    out_name: str = "label_images_true_landmarks") -> Path:  # fmt: skip
    """The image meshes of ``WORK/meshes`` corresponded with the true landmark table (cached)."""
    src = work / f"{meshes}_true_landmarks"
    out = work / "corresponded" / out_name
    if not (out / "quality.csv").is_file():
        if not src.is_dir():
            shutil.copytree(work / meshes, src)
        table = {"atlas": synthetic_landmarks(data.cohort.atlas)}
        for s in data.cohort.subjects:
            table[s.name] = synthetic_landmarks(s.ed).transformed(poses[s.name])
        write_landmarks(src / "landmarks.csv", table)
        atlas = work / "segmentations" / "posed" / "atlas.vtk"
        correspond_cohort(atlas, src, out, CorrespondenceSettings(), jobs=jobs)
    return out


def _meshing(data, poses, meshes: Path) -> tuple[np.ndarray, np.ndarray]:
    """Per subject: the mean distance of the meshed ED to the true surface, and its signed mean
    (outward positive)."""
    out = []
    for s in data.cohort.subjects:
        v, _ = read_mesh(meshes / f"{s.name}_ed.vtk")
        d = _distance(poses[s.name].apply(s.ed), data.cohort.faces, v, signed=True)
        out.append((np.abs(d).mean(), d.mean()))
    return np.array(out).T


def _septum_errors(data, poses, meshes: Path) -> np.ndarray:
    """Per subject: the angle (degrees) of the septal direction of ``meshes``' landmark table
    from the true one."""
    table = read_landmarks(meshes / "landmarks.csv")
    errors = []
    for s in data.cohort.subjects:
        true = synthetic_landmarks(s.ed).transformed(poses[s.name]).septal_direction
        cosine = np.clip(table[s.name].septal_direction @ true, -1.0, 1.0)
        errors.append(np.degrees(np.arccos(cosine)))
    return np.array(errors)


def _septum_about_the_true_axis(data, poses, work: Path) -> np.ndarray:
    """Per subject: the error (degrees) of the RV centroid's direction taken about the
    true long axis (the line through the true apex) instead of the estimated one: what
    the RV label itself leaves, whatever the axis."""
    errors = []
    for s in data.cohort.subjects:
        true = synthetic_landmarks(s.ed).transformed(poses[s.name])
        image = read_label_image(work / "images" / f"{s.name}_ed.nii.gz")
        offset = label_centroid(image, 2) - true.apex
        radial = offset - (offset @ true.long_axis) * true.long_axis
        cosine = np.clip(radial @ true.septal_direction / np.linalg.norm(radial), -1.0, 1.0)
        errors.append(np.degrees(np.arccos(cosine)))
    return np.array(errors)


def _lid_route(data, poses, work: Path, jobs: int) -> tuple[Path, Path]:
    """The label images meshed with the lid removed by its normals, and corresponded (cached)."""
    from ladders.study.imaging import MeshingSettings, mesh_label_images

    meshes = work / "images_meshed_lid"
    out = work / "corresponded" / "label_images_lid"
    if not (meshes / "landmarks.csv").is_file() or "atlas" not in read_landmarks(
        meshes / "landmarks.csv"
    ):
        planes = {}
        for s in data.cohort.subjects:
            for phase, v in (("ed", s.ed), ("es", s.es)):
                top = poses[s.name].apply(np.array([[0.0, 0.0, v[:, 2].max()]]))[0]
                planes[f"{s.name}_{phase}.nii.gz"] = (*top, *(poses[s.name].rotation @ [0, 0, 1.0]))
        settings = MeshingSettings(cut_margin=0.0, lid_angle=45.0)
        mesh_label_images(sorted((work / "images").iterdir()), 1, meshes, settings=settings,
                          cut_planes=planes, progress=False, rv_label=2, jobs=jobs)  # fmt: skip
        table = {"atlas": synthetic_landmarks(data.cohort.atlas),
                 **read_landmarks(meshes / "landmarks.csv")}  # fmt: skip
        write_landmarks(meshes / "landmarks.csv", table)
    if not (out / "quality.csv").is_file():
        atlas = work / "segmentations" / "posed" / "atlas.vtk"
        correspond_cohort(atlas, meshes, out, CorrespondenceSettings(), jobs=jobs)
    return meshes, out


def _rim_gap(data, poses, folder: Path) -> np.ndarray:
    """Per subject: mean height of the meshed ED's rim below the true valve plane (mm)."""
    gaps = []
    for s in data.cohort.subjects:
        v, f = read_mesh(folder / f"{s.name}_ed.vtk")
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        unique, counts = np.unique(edges, axis=0, return_counts=True)
        rim = np.unique(unique[counts == 1])
        height = poses[s.name].inverse().apply(v[rim])[:, 2]
        gaps.append(s.ed[:, 2].max() - height.mean())
    return np.array(gaps)


def _harmonic_floor(n: int) -> list[tuple[str, np.ndarray]]:
    """ED vertex errors of the correspondence on true surfaces, with and without harmonics."""
    out = []
    for label, model, marks in (
        ("default model", None, False),
        ("default model, landmark table (apex and base anchor the affine fit)", None, True),
        ("no wall harmonics", SyntheticLVModel(harmonic_amplitude=0.0), False),
    ):
        data = make_two_group_cohort(n_subjects=n, seed=3, model=model)
        faces, errors = data.cohort.faces, []
        atlas_marks = synthetic_landmarks(data.cohort.atlas) if marks else None
        for s in data.cohort.subjects:
            v, f = remesh(s.ed, faces, len(faces))
            done = correspond_mesh(data.cohort.atlas, faces, v, f,
                                   CorrespondenceSettings(alignment="none"),
                                   landmarks=synthetic_landmarks(s.ed) if marks else None,
                                   template_landmarks=atlas_marks)  # fmt: skip
            errors.append(np.linalg.norm(done.vertices - s.ed, axis=1).mean())
        out.append((label, np.array(errors)))
        print(label, _cell(errors), flush=True)
    return out


#: The landmarks' anchoring of the affine fit compared in the third table.
ANCHORS = (("none", {"anchor_weight": 0.0}), ("axial (default)", {}),
           ("whole points", {"anchor": "points"}))  # fmt: skip


def _base_landmark(data, poses, work: Path) -> tuple[np.ndarray, ...]:
    """Per subject: the RV route's base-plane centre against the true one, along the true long
    axis (positive toward the base) and aside of it; and the centre of the section the true
    mesh's own rim encloses, aside of the true one (mm)."""
    from ladders.study.imaging.septum import lv_apex_and_base

    table = read_landmarks(work / "images_meshed" / "landmarks.csv")
    along, aside, own = [], [], []
    for s in data.cohort.subjects:
        true = synthetic_landmarks(s.ed).transformed(poses[s.name])
        d = table[s.name].base - true.base
        along.append(d @ true.long_axis)
        aside.append(np.linalg.norm(d - (d @ true.long_axis) * true.long_axis))
        rim = lv_apex_and_base(s.ed, data.cohort.faces)[1]  # an open mesh: its rim's section
        e = rim - synthetic_landmarks(s.ed).base
        own.append(np.linalg.norm(e[:2]))
    return np.array(along), np.array(aside), np.array(own)


#: The correspondence's alpha^2 (regularisation weight) of the second table.
ALPHA2 = (0.1, 1.0, 10.0, 100.0)
#: (row label, folder of meshes, folder of the default correspondence) of the sweeps.
_SOURCES = (
    ("label images, RV landmarks", "images_meshed", IMAGES),
    ("label images, true landmark table", "images_meshed_true_landmarks",
     "label_images_true_landmarks"),
    ("true surfaces remeshed, landmark table", "segmentations/posed", TRUE_SURFACES),
)  # fmt: skip


def _sweep(data, poses, work: Path, jobs: int, variants, column: int) -> list[str]:
    """Rows of the ED vertex error, one per source of ``_SOURCES``, one cell per variant
    ``(folder suffix or None for the default, settings changes)``; each cell: median / max
    of the error, then the median of ``_errors``' column ``column`` (each correspondence
    cached in WORK)."""
    lines = []
    for label, src, done in _SOURCES:
        cells = []
        for suffix, changes in variants:
            out = work / "corresponded" / done
            if suffix is not None:
                out = out.with_name(f"{done}_{suffix}")
                if not (out / "quality.csv").is_file():
                    correspond_cohort(work / "segmentations" / "posed" / "atlas.vtk", work / src,
                                      out, CorrespondenceSettings(**changes), jobs=jobs)  # fmt: skip
            e = _errors(data, poses, out)
            cells.append(f"{_cell(e[:, 0])}; {np.median(e[:, column]):.2f}")
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    return lines


def _sweep_table(caption: str, names, rows) -> list[str]:
    """A sweep's caption and table (its first column: the ED meshes)."""
    return ["", caption, "", "| ED meshes | " + " | ".join(names) + " |",
            "|---|" + "---|" * len(names), *rows]  # fmt: skip


def _cell(values) -> str:
    return f"{np.median(values):.2f} / {np.max(values):.2f}"


def _spread(values) -> str:
    return f"{np.min(values):.2f} / {np.median(values):.2f} / {np.max(values):.2f}"


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, required=True)
    parser.add_argument("--subjects", type=int, default=20)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    print(machine(), flush=True)
    data = make_two_group_cohort(n_subjects=args.subjects, seed=3)
    truth = json.loads((args.work / "segmentations" / "posed" / "planted_region.json").read_text())
    poses = {n: SimilarityTransform.from_matrix(np.array(m)) for n, m in truth["poses"].items()}
    meshing, signed = _meshing(data, poses, args.work / "images_meshed")
    septum = _septum_errors(data, poses, args.work / "images_meshed")
    rv = _errors(data, poses, args.work / "corresponded" / IMAGES)
    centroid = _errors(data, poses, args.work / "corresponded" / CENTROID)
    centroid_septum = _septum_errors(data, poses, args.work / "images_meshed_centroid")
    exact = _errors(data, poses, _true_landmarks(data, poses, args.work, args.jobs))
    lid_meshes, lid_out = _lid_route(data, poses, args.work, args.jobs)
    lid = _errors(data, poses, lid_out)
    lid_exact = _errors(data, poses, _true_landmarks(data, poses, args.work, args.jobs,
                                                     "images_meshed_lid",
                                                     "label_images_lid_true_landmarks"))  # fmt: skip
    about_true_axis = _septum_about_the_true_axis(data, poses, args.work)
    surfaces = _errors(data, poses, args.work / "corresponded" / TRUE_SURFACES)[:, 0]
    lid_meshing, lid_signed = _meshing(data, poses, lid_meshes)
    lid_septum = _septum_errors(data, poses, lid_meshes)
    base_along, base_aside, base_own = _base_landmark(data, poses, args.work)
    gap = _rim_gap(data, poses, args.work / "images_meshed")
    lid_gap = _rim_gap(data, poses, lid_meshes)
    cols = (rv, exact, lid, lid_exact)

    def row(label, i):
        return f"| {label} | " + " | ".join(_cell(c[:, i]) for c in cols) + " |"

    lines = [
        "| label images (1.5 mm), posed, median / max over the subjects | landmarks from the RV "
        "label | true landmark table | lid removed by its normals, RV landmarks | lid removed "
        "by its normals, true landmark table |",
        "|---|---|---|---|---|",
        f"| meshed end-diastole to the true surface (mm) | {_cell(meshing)} | same meshes | "
        f"{_cell(lid_meshing)} | same meshes |",
        f"| the same, signed (outward positive): mean over the vertices, min / median / max "
        f"over the subjects (mm) | {_spread(signed)} | same meshes | {_spread(lid_signed)} | "
        "same meshes |",
        f"| rim below the true base (mm) | {_cell(gap)} | same meshes | {_cell(lid_gap)} | "
        "same meshes |",
        f"| septal direction from the RV label, error (deg) | {_cell(septum)} | 0 | "
        f"{_cell(lid_septum)} | 0 |",
        f"| the same, toward the RV's centroid (`rv_septum='centroid'`) (deg) | "
        f"{_cell(centroid_septum)} | - | - | - |",
        f"| the same, the RV's centroid taken about the true long axis (deg) | "
        f"{_cell(about_true_axis)} | - | - | - |",
        f"| base-plane centre from the RV route: its distance to the true valve plane; its "
        f"distance aside of the true long axis (mm) | {_cell(np.abs(base_along))}; "
        f"{_cell(base_aside)} | 0; 0 | - | 0; 0 |",
        f"| the true mesh's own rim: the centre of the section it encloses, aside of the "
        f"model's axis point (mm) | {_cell(base_own)} | - | - | - |",
        row("rotation left (deg)", 3),
        row("ED vertex error to the true material points (mm)", 0),
        f"| the same with the septum toward the RV's centroid (mm) | {_cell(centroid[:, 0])} | "
        "- | - | - |",
        "| the same minus that on the subject's true surface (remeshed, landmark table): "
        "min / median / max (mm) | " + " | ".join(_spread(c[:, 0] - surfaces) for c in cols) + " |",
        row("its part along the true normals (mm)", 1),
        row("basal fifth: mean error along the long axis, toward the base (mm)", 4),
        row("corresponded vertices to the true surface (mm)", 2),
        row("error about the long axis: its mean, a turn (mm)", 5),
        row("error about the long axis: mean deviation from that turn (mm)", 6),
    ]
    default = CorrespondenceSettings()
    alphas = [(None if np.isclose(a, default.alpha**2) else f"alpha2_{a:g}",
               {"alpha": float(np.sqrt(a))}) for a in ALPHA2]  # fmt: skip
    lines += _sweep_table(
        "The correspondence's regularisation: the same 20 subjects corresponded with "
        "`CorrespondenceSettings(alpha=sqrt(alpha^2))` (the default is alpha^2 = 0.1). Each "
        "cell: ED vertex error to the true material points, median / max over the subjects; "
        "then its part along the true normals, median (mm).",
        [f"alpha^2 = {a:g}" for a in ALPHA2],
        _sweep(data, poses, args.work, args.jobs, alphas, 1),
    )
    anchors = [(None if not change else f"anchor_{name.split()[0]}", change)
               for name, change in ANCHORS]  # fmt: skip
    lines += _sweep_table(
        "The landmarks' anchoring of the affine fit (`CorrespondenceSettings(anchor=..., "
        "anchor_weight=...)`): none (`anchor_weight=0`), the apex's and base-plane centre's "
        "heights along the long axis (the default), or the whole points. Each cell: ED vertex "
        "error to the true material points, median / max over the subjects; then the basal "
        "fifth's mean error along the long axis, median (mm).",
        [name for name, _ in ANCHORS],
        _sweep(data, poses, args.work, args.jobs, anchors, 4),
    )
    floor = _harmonic_floor(args.subjects)
    lines += [
        "",
        "The floor set by the wall's harmonics: the same subjects' true ED surfaces, unposed "
        "and remeshed, corresponded with the default settings and no rigid alignment "
        "(`alignment='none'`): with the default model, with it and the true landmark table "
        "(its apex and base anchor the affine fit), and with its azimuthal harmonics set to "
        "zero (`SyntheticLVModel(harmonic_amplitude=0)`).",
        "",
        "| true ED surfaces, unposed, remeshed | ED vertex error to the true material points, "
        "median / max (mm) |",
        "|---|---|",
        *(f"| {label} | {_cell(e)} |" for label, e in floor),
    ]
    table = (
        f"{args.subjects} subjects of the orientation benchmark's label-image condition, "
        "corresponded with the default settings.\n\n" + "\n".join(lines) + "\n"
    )
    print(table)
    if args.publish:
        publish("orientation_images", table,
                "python benchmarks/bench_image_route.py --work WORK --publish")  # fmt: skip


if __name__ == "__main__":
    main()
