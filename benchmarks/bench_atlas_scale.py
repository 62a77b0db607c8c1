"""The atlas at population scale: its cost against the cohort's size, and an atlas from a subset.

    python benchmarks/bench_atlas_scale.py --work WORK             # every part, resumed
    python benchmarks/bench_atlas_scale.py --work WORK --parts scale
    python benchmarks/bench_atlas_scale.py --work WORK --publish   # the tables, from WORK

The cohort is that of the own-data tutorial, as label images
(:func:`write_label_images`: the two-group synthetic cohort, the
hypokinesia in half the subjects, 1.5 mm voxels, LV and RV labels, the valve planes),
``--subjects`` of them (default 200), meshed by the tutorial's ``symladders mesh``
command (about 1,000 vertices per mesh). Parts:

* ``proxy``: the sampling error of a subset apart from any registration: on the
  generator's ED meshes in true correspondence (200 and 1,000 subjects), the
  Procrustes mean of a subset of 12, 25, 50, 100 (stratified, and 20 random draws)
  against the whole cohort's, and the standard error a random draw is expected to have.
* ``scale``: ``build_atlas`` with the defaults of ``symladders atlas`` (varifold term,
  landmark table, start at the first subject, ``tol`` 0.1 mm, at most 10 iterations) on
  the first N ED meshes, N in ``--sizes`` (default 12, 24), ``--jobs`` workers: every
  evaluation's wall time, load and processor time (summed over its registrations), the
  iterations and each iteration's move.
* ``evaluations``: the start's evaluation alone (``max_iter=0``) on the first N, N in
  ``--evaluation-sizes`` (default 50): one evaluation's cost where a whole atlas is not run.
* ``subset``: the atlas of ``--subset-sizes`` (default 12) of the first ``--cohort``
  (default 24) subjects, stratified (seed 0) and random (``--seeds``, default 0), from the
  same start as the atlas of all of them, against it: per-vertex RMS after Procrustes
  (the atlases share the start's triangulation) and mean surface distance.
* ``route``: ``symladders mesh`` on the ``--cohort`` subjects' images alone, then
  ``correspond``, ``study --alpha2 100`` and ``analyze`` of those subjects onto the atlas of
  all of them and onto the stratified subset's (``--route-subset``): the processor time of
  each command with its workers, the correspondence's quality table, and the planted
  region's power and Dice (1,000 permutations; the region carried onto each atlas from
  the generator's mean shape by closest vertex).

``--publish`` writes ``docs/generated/atlas_subset_proxy.md``, ``atlas_subset.md`` and
``atlas_scale.md`` (one row per CPU): the timings, and the whole route for 1,000 subjects
with an atlas of 50 extrapolated from the processor time measured per subject and per
registration (the atlas: reading and describing 1,000 meshes, 50 rigid alignments, the
evaluations the atlases above took, each 50 registrations; analyze scaled linearly with
the subjects). Every atlas is written in ``WORK/atlases`` with its record and timing; a
rerun reuses them.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import os
import shlex
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from generated_tables import publish, publish_rows  # noqa: E402

from ladders.study.meshes import read_mesh  # noqa: E402
from ladders.study.preparation import (  # noqa: E402
    icp_align,
    procrustes,
    read_atlas_inputs,
    surface_distances,
    vertex_error_components,
)
from ladders.study.preparation.atlas_run import build_atlas  # noqa: E402
from ladders.study.preparation.landmarks import read_landmarks, write_landmarks  # noqa: E402

MESH = ("symladders mesh images/*.nii.gz --label 1 --rv-label 2 --cut-planes planes.csv "
        "--vertices 1000 -o meshes")  # fmt: skip


def _load() -> float:
    return round(os.getloadavg()[0], 1)


def _cli(command: str, cwd: Path, extra=()) -> dict:
    """A ``symladders`` command run in ``cwd`` (globs expanded), timed, with the load and
    the processor time of the command and its worker processes."""
    import glob
    import resource

    argv = []
    for arg in shlex.split(command)[1:]:
        found = sorted(glob.glob(arg, root_dir=cwd)) if "*" in arg else [arg]
        argv += found
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "ladders.study.cli", *argv, *extra], cwd=cwd,
                          capture_output=True, text=True, check=False)  # fmt: skip
    seconds = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode not in (0, 1):
        raise RuntimeError(f"{command}: exit {done.returncode}: {done.stderr[-2000:]}")
    return {"command": command, "seconds": seconds, "cpu_seconds": cpu, "load": _load(),
            "status": done.returncode}  # fmt: skip


def _stored(path: Path, make) -> dict:
    """The JSON at ``path``, made by ``make()`` when it is not there."""
    if path.is_file():
        return json.loads(path.read_text())
    value = make()
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(value, indent=1))
    return value


def write_label_images(
    folder, n_subjects: int = 20, spacing: float = 1.5, n_vertices: int = 1009, seed: int = 0
):
    """Label images, ``planes.csv`` and ``groups.csv`` of a synthetic two-group cohort, as
    the own-data tutorial's cohort was written when the tables were measured (subjects
    ``case01``, ...; LV label 1, RV label 2; each frame's valve plane in ``planes.csv``).

    Returns the :class:`~ladders.study.population.TwoGroupCohort` (its subjects renamed
    ``case01``, ... as the files are) and ``{old name: new name}``.
    """
    from ladders.study.imaging import add_rv_label, voxelize, write_label_image
    from ladders.study.population import make_two_group_cohort
    from ladders.study.preparation.synthetic_landmarks import synthetic_landmarks

    folder = Path(folder)
    images = folder / "images"
    data = make_two_group_cohort(n_subjects, n_vertices=n_vertices, seed=seed)
    names = {s.name: f"case{i + 1:02d}" for i, s in enumerate(data.cohort.subjects)}
    planes = []
    for s in data.cohort.subjects:
        both = np.vstack([s.ed, s.es])
        low = both.min(axis=0) - 22.0  # room for the right ventricle beside the septum
        shape = tuple(int(n) for n in np.ceil((both.max(axis=0) + 22.0 - low) / spacing))
        affine = np.diag([spacing, spacing, spacing, 1.0])
        affine[:3, 3] = low
        apex = synthetic_landmarks(s.ed).apex
        for phase in ("ed", "es"):
            v = getattr(s, phase)
            top = (0.0, 0.0, float(v[:, 2].max()))  # the valve plane of this frame, z up
            labels = voxelize(v, data.cohort.faces, affine, shape, label=1)
            labels = add_rv_label(labels, affine, apex, top, (-1.0, 0.0, 0.0), rv_label=2)
            name = f"{names[s.name]}_{phase}.nii.gz"
            write_label_image(images / name, labels, affine)
            planes.append((name, *top, 0.0, 0.0, 1.0))
    with open(folder / "planes.csv", "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(["image", "x", "y", "z", "nx", "ny", "nz"])
        writer.writerows([p[0], *(f"{x:.3f}" for x in p[1:])] for p in planes)
    with open(folder / "groups.csv", "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(["subject", "group"])
        writer.writerows((names[k], g) for k, g in data.groups.items())
    return data, names


def cohort(work: Path, n: int) -> dict:
    """The label images and their meshes (``symladders mesh``, timed) of ``n`` subjects."""
    if not (work / "groups.csv").is_file():
        write_label_images(work, n, 1.5)
    return _stored(work / "times" / "mesh.json", lambda: {**_cli(MESH, work), "subjects": n})


def first_inputs(folder: Path, n: int):
    """The atlas inputs of the first ``n`` subjects of a folder of meshes."""
    everyone = read_atlas_inputs(folder)
    return dataclasses.replace(everyone, names=everyone.names[:n], meshes=everyone.meshes[:n],
                               files=everyone.files[:n])  # fmt: skip


def _inputs(work: Path, n: int):
    return first_inputs(work / "meshes", n)


def timed_atlas(work: Path, name: str, inputs, jobs: int, **options) -> dict:
    """``build_atlas`` into ``WORK/atlases/<name>.vtk``, the time of every evaluation."""
    output = work / "atlases" / f"{name}.vtk"

    def make() -> dict:
        marks = [time.perf_counter()]
        loads = []

        def progress(it, objective, norm):
            marks.append(time.perf_counter())
            loads.append(_load())
            print(f"  {name}: iteration {it}: objective {objective:.6g}, "
                  f"{marks[-1] - marks[-2]:.0f} s, load {loads[-1]}", flush=True)  # fmt: skip

        table = read_landmarks(work / "meshes" / "landmarks.csv")  # the subjects' rows only
        run = build_atlas(work / "meshes", output, inputs=inputs, jobs=jobs, progress=progress,
                          landmarks={n: table[n] for n in inputs.names}, **options)  # fmt: skip
        return {
            "subjects": len(run.record["subjects"]), "n_iter": run.record["n_iter"],
            "converged": run.record["converged"], "seconds": list(np.diff(marks)),
            "total": marks[-1] - marks[0], "loads": loads, "jobs": jobs,
            "n_registrations": run.record["n_registrations"],
            "cpu_seconds": run.record["cpu_seconds"], "moves": run.record["moves"],
        }  # fmt: skip

    return _stored(work / "atlases" / f"{name}.timing.json", make)


def part_scale(work: Path, sizes, jobs: int) -> list[dict]:
    rows = []
    for n in sizes:
        print(f"atlas of {n} subjects", flush=True)
        rows.append(timed_atlas(work, f"all_{n}", _inputs(work, n), jobs, subset=None))
    return rows


def part_evaluations(work: Path, sizes, jobs: int) -> list[dict]:
    """The start's evaluation alone (``max_iter=0``: one registration per subject) on the
    first N subjects: what one evaluation costs at sizes a whole atlas is not run at."""
    return [
        timed_atlas(work, f"start_{n}", _inputs(work, n), jobs, max_iter=0, subset=None)
        for n in sizes
    ]


def fit_growth(rows) -> tuple[float, float]:
    """``(a, b)`` of seconds per evaluation ``= a + b N`` (least squares)."""
    n = np.array([r["subjects"] for r in rows], dtype=float)
    per = np.array([np.mean(r["seconds"]) for r in rows])
    b, a = np.polyfit(n, per, 1)
    return float(a), float(b)


def atlas_distance(work: Path, name: str, reference: str) -> dict:
    """Per-vertex RMS after Procrustes (split along the reference's normals and along its
    surface) of two atlases that share a triangulation (the same start), and the mean
    surface distance; atlases from different starts: rigid ICP, the surface distance only."""
    v, f = read_mesh(work / "atlases" / f"{name}.vtk")
    ref, ref_f = read_mesh(work / "atlases" / f"{reference}.vtk")
    if v.shape != ref.shape or not np.array_equal(f, ref_f):
        moved = icp_align(v, f, ref, ref_f)[0].apply(v)
        surface = surface_distances(moved, f, ref, ref_f)["mean_surface_distance"]
        return {"surface": float(surface)}
    moved = procrustes(v, ref).apply(v)
    parts = vertex_error_components(ref, moved, ref_f)
    surface = surface_distances(moved, f, ref, ref_f)["mean_surface_distance"]
    return {"rms": parts["total"], "normal": parts["normal"], "tangential": parts["tangential"],
            "surface": float(surface)}  # fmt: skip


def part_subset(work: Path, n_cohort: int, sizes, seeds, jobs: int) -> list[dict]:
    inputs = _inputs(work, n_cohort)
    start = inputs.names[0]
    rows = []
    for size in sizes:
        for rule, draws in (("stratified", (0,)), ("random", seeds or ())):
            for seed in draws:
                name = f"{rule}{seed}_{size}_of_{n_cohort}"
                print(f"atlas {name}", flush=True)
                timing = timed_atlas(work, name, inputs, jobs, subset=size, subset_rule=rule,
                                     subset_seed=seed, start=start)  # fmt: skip
                rows.append({"size": size, "rule": rule, "seed": seed, **timing,
                             **atlas_distance(work, name, f"all_{n_cohort}")})  # fmt: skip
    # the atlas of all from another start: how far two estimates of one mean lie apart
    timed_atlas(work, f"all_{n_cohort}_start2", inputs, jobs, subset=None, start=inputs.names[1])
    return rows


def procrustes_mean(shapes, weights=None, n_iter: int = 5) -> np.ndarray:
    """The (weighted) generalised Procrustes mean of shapes in correspondence."""
    w = np.full(len(shapes), 1.0 / len(shapes)) if weights is None else np.asarray(weights)
    mean = shapes[0]
    for _ in range(n_iter):
        mean = np.tensordot(w, np.stack([procrustes(x, mean).apply(x) for x in shapes]), 1)
    return mean


def _rms_after_procrustes(a, b) -> float:
    return float(np.sqrt(((procrustes(a, b).apply(a) - b) ** 2).sum(1).mean()))


def part_proxy(cohorts, sizes, seeds: int = 20) -> list[dict]:
    """The sampling error of a subset alone, without registration: on the generator's ED
    meshes in true correspondence, the distance of a subset's Procrustes mean (stratified:
    weighted by the strata) to the whole cohort's, and the subjects' spread about it."""
    from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
    from ladders.study.preparation import choose_atlas_subset, shape_descriptor

    rows = []
    for m in cohorts:
        c = make_synthetic_cohort(m, n_vertices=1009, seed=0)
        shapes = np.stack([s.ed for s in c.subjects])
        full = procrustes_mean(shapes)
        spread = float(np.sqrt(np.mean([_rms_after_procrustes(x, full) ** 2 for x in shapes])))
        descriptors = np.array([shape_descriptor(x, c.faces) for x in shapes])
        aligned = np.stack([procrustes(x, full).apply(x) for x in shapes]).reshape(m, -1)
        design = np.column_stack([np.ones(m), descriptors])
        fit = design @ np.linalg.lstsq(design, aligned, rcond=None)[0]
        explained = 1.0 - ((aligned - fit) ** 2).sum() / ((aligned - aligned.mean(0)) ** 2).sum()
        for n in sizes:
            strat = choose_atlas_subset(descriptors, n, "stratified", 0)
            errors = {"stratified": [_rms_after_procrustes(
                procrustes_mean(shapes[strat.indices], strat.weights), full)]}  # fmt: skip
            errors["random"] = [
                _rms_after_procrustes(procrustes_mean(shapes[np.sort(
                    np.random.default_rng(seed).choice(m, n, replace=False))]), full)
                for seed in range(seeds)
            ]  # fmt: skip
            theory = spread * np.sqrt((m - n) / (n * (m - 1)))
            rows.append({"cohort": m, "size": n, "spread": spread, "theory": float(theory),
                         "explained": float(explained),
                         "stratified": errors["stratified"][0],
                         "random_rms": float(np.sqrt(np.mean(np.square(errors["random"])))),
                         "random_p95": float(np.percentile(errors["random"], 95))})  # fmt: skip
            print(rows[-1], flush=True)
    return rows


def _sample(work: Path, n: int) -> Path:
    """``WORK/meshes_<n>``: the first ``n`` subjects' meshes (links), the landmark table and
    ``groups_<n>.csv``."""
    folder = work / f"meshes_{n}"
    names = read_atlas_inputs(work / "meshes").names[:n]
    if not folder.is_dir():
        folder.mkdir()
        for name in names:
            for phase in ("ed", "es"):
                (folder / f"{name}_{phase}.vtk").symlink_to(work / "meshes" / f"{name}_{phase}.vtk")
        table = read_landmarks(work / "meshes" / "landmarks.csv")
        write_landmarks(folder / "landmarks.csv", {n: table[n] for n in names})
    rows = (work / "groups.csv").read_text().splitlines()
    keep = set(names)
    (work / f"groups_{n}.csv").write_text(
        "\n".join([rows[0], *(r for r in rows[1:] if r.split(",")[0] in keep)]) + "\n"
    )
    return folder


def mesh_sample(work: Path, n: int) -> dict:
    """``symladders mesh`` on the first ``n`` subjects' images alone (timed, processor time)."""
    names = read_atlas_inputs(work / "meshes").names[:n]
    images = " ".join(f"images/{s}_{p}.nii.gz" for s in names for p in ("ed", "es"))
    command = MESH.replace("images/*.nii.gz", images).replace("-o meshes", f"-o meshes_sample{n}")
    return _stored(
        work / "times" / f"mesh_{n}.json", lambda: {**_cli(command, work), "subjects": n}
    )


def _region_on(vertices, data) -> np.ndarray:
    """The planted region carried onto an atlas (in the generator's frame) by closest vertex
    of the generator's mean shape."""
    from scipy.spatial import cKDTree

    _, index = cKDTree(data.cohort.atlas).query(vertices)
    return data.region.affected[index]


def route(work: Path, atlas: str, n: int, permutations: int) -> dict:
    """correspond, study (alpha^2 = 100) and analyze the first ``n`` subjects onto ``atlas``:
    times, quality, power and Dice of the planted region."""
    from ladders.study.population import (
        load_transported_motion,
        make_two_group_cohort,
        score_transports,
    )

    folder, out = _sample(work, n), work / "route" / atlas
    rel = os.path.relpath
    steps = {
        "correspond": f"symladders correspond --atlas {rel(work / 'atlases' / f'{atlas}.vtk', work)} "
        f"--meshes {rel(folder, work)} -o {rel(out / 'corresponded', work)} --no-progress -j 2",
        "study": f"symladders study --meshes {rel(out / 'corresponded', work)} --alpha2 100 "
        f"-o {rel(out / 'study', work)} --no-progress -j 2",
        "analyze": f"symladders analyze {rel(out / 'study', work)} --groups groups_{n}.csv "
        "--no-progress --no-figures",
    }  # fmt: skip
    times = {k: _stored(out / f"{k}.json", lambda c=c: _cli(c, work)) for k, c in steps.items()}
    with open(out / "corresponded" / "quality.csv", encoding="utf-8") as fh:
        quality = [r for r in csv.DictReader(fh) if r.get("phase", "ed") == "ed"]
    msd = [float(r["mean_surface_distance"]) for r in quality if r.get("mean_surface_distance")]
    hd = [float(r["hausdorff"]) for r in quality if r.get("hausdorff")]
    flagged = sum(r.get("flagged", "").lower() in ("true", "yes", "1") for r in quality)

    def scores() -> dict:
        data = make_two_group_cohort(args_subjects(work), seed=0)
        names = {s.name: f"case{i + 1:02d}" for i, s in enumerate(data.cohort.subjects)}
        groups = {names[k]: g for k, g in data.groups.items()}
        motions = [m for m in load_transported_motion(out / "study") if m.method != "none"]
        atlas_v = read_mesh(work / "atlases" / f"{atlas}.vtk")[0]
        subjects = list(motions[0].subjects)
        labels = np.array([groups[s] == "patients" for s in subjects])
        found, _ = score_transports(motions, labels, _region_on(atlas_v, data),
                                    np.random.default_rng(0), None, permutations)  # fmt: skip
        return {s.label: {"power": s.power, "dice": s.dice} for s in found}

    return {"times": times, "quality": {"mean_surface_distance": float(np.median(msd)),
            "hausdorff": float(np.median(hd)), "flagged": int(flagged), "meshes": len(quality)},
            "scores": _stored(out / f"scores_{permutations}.json", scores)}  # fmt: skip


def args_subjects(work: Path) -> int:
    return len(read_atlas_inputs(work / "meshes").names)


def alignment_cost(work: Path, n: int = 6) -> float:
    """Processor seconds of one rigid alignment onto the start (``fit_rigid`` with the
    landmark table), the mean over ``n`` subjects."""
    from ladders.study.preparation import CorrespondenceSettings, read_landmarks
    from ladders.study.preparation.atlas import align_onto_start

    def make() -> dict:
        inputs = _inputs(work, n + 1)
        table = read_landmarks(work / "meshes" / "landmarks.csv")
        start = time.process_time()
        for name, (v, f) in zip(inputs.names[1:], inputs.meshes[1:]):
            align_onto_start(v, f, *inputs.meshes[0], CorrespondenceSettings(), table[name],
                             table[inputs.names[0]])  # fmt: skip
        return {"cpu_seconds": (time.process_time() - start) / n}

    return _stored(work / "times" / "alignment.json", make)["cpu_seconds"]


def reading_cost(work: Path) -> float:
    """Processor seconds per subject of reading the ED meshes and their descriptors."""
    from ladders.study.preparation import shape_descriptor

    def make() -> dict:
        start = time.process_time()
        inputs = read_atlas_inputs(work / "meshes")
        for v, f in inputs.meshes:
            shape_descriptor(v, f)
        return {"cpu_seconds": (time.process_time() - start) / len(inputs.names)}

    return _stored(work / "times" / "reading.json", make)["cpu_seconds"]


def _timing(work: Path, name: str) -> dict | None:
    path = work / "atlases" / f"{name}.timing.json"
    return json.loads(path.read_text()) if path.is_file() else None


def extrapolate(work: Path, n_subjects: int, subset: int, route_cohort: int) -> dict:
    """Processor seconds of the whole route for ``n_subjects`` with an atlas of ``subset``:
    the per-subject steps measured on ``route_cohort`` subjects, the atlas from its
    measured cost per registration and number of evaluations."""
    runs = [t for t in (_timing(work, f"all_{n}") for n in (12, 24, 50)) if t]
    per_start = np.mean([t["cpu_seconds"][0] / t["subjects"] for t in runs])
    per_iter = np.mean([c / t["subjects"] for t in runs for c in t["cpu_seconds"][1:]])
    evaluations = max(len(t["cpu_seconds"]) for t in runs)
    atlas = (n_subjects * reading_cost(work) + subset * alignment_cost(work)
             + subset * (per_start + (evaluations - 1) * per_iter))  # fmt: skip
    mesh = json.loads((work / "times" / f"mesh_{route_cohort}.json").read_text())
    steps = {"mesh": mesh["cpu_seconds"] / route_cohort}
    for step in ("correspond", "study", "analyze"):
        found = [json.loads(p.read_text())["cpu_seconds"]
                 for p in (work / "route").glob(f"*/{step}.json")]  # fmt: skip
        steps[step] = float(np.mean(found)) / route_cohort
    total = atlas + n_subjects * sum(steps.values())
    return {"per_registration_start": float(per_start), "per_registration": float(per_iter),
            "evaluations": evaluations, "atlas": float(atlas), "steps": steps,
            "total": float(total), "hours_on_2_cores": total / 2 / 3600}  # fmt: skip


COMMAND = "python benchmarks/bench_atlas_scale.py --work WORK"


def proxy_table(rows) -> str:
    spread = {r["cohort"]: r["spread"] for r in rows}
    explained = {r["cohort"]: r["explained"] for r in rows}
    lines = [
        "The sampling error of an atlas from a subset, apart from any registration: the "
        "generator's ED meshes (1,009 vertices) in their true correspondence, the "
        "(weighted) generalised Procrustes mean of a subset against that of the whole "
        "cohort, per-vertex RMS after Procrustes. Stratified: the rule of `--subset` (seed "
        "0); random: 20 seeded draws; expected: `s sqrt((M - N) / (N (M - 1)))`, the "
        "standard error of a mean of N drawn without replacement, `s` the subjects' RMS "
        "distance to the cohort's mean shape ("
        + ", ".join(f"{s:.2f} mm for {m} subjects" for m, s in spread.items()) + "). "
        "The descriptor (three principal extents) explains, linearly, "
        + " and ".join(f"{100 * e:.0f} %" for e in explained.values())
        + " of the aligned shapes' variance here; strata remove only the part of the "
        "variance between them, so in a cohort whose shapes vary in other ways the "
        "stratified error lies nearer the random draw's.",
        "",
        "| cohort M | subset N | stratified (mm) | random: RMS / 95th percentile (mm) | "
        "random, expected RMS (mm) |",
        "|---:|---:|---:|---:|---:|",
    ]  # fmt: skip
    lines += [
        f"| {r['cohort']} | {r['size']} | {r['stratified']:.2f} | {r['random_rms']:.2f} / "
        f"{r['random_p95']:.2f} | {r['theory']:.2f} |" for r in rows
    ]  # fmt: skip
    return "\n".join(lines)


def _transports(scores: dict) -> str:
    return "; ".join(f"{k}: {v['power']:.2f} / {v['dice']:.2f}" for k, v in scores.items())


def subset_table(work: Path, cohort_n: int, subset_n: int) -> str:
    """The LDDMM atlases of the label-image meshes: the subset's against all's, and the route."""
    ref = f"all_{cohort_n}"
    names = [ref] + sorted(
        p.stem.removesuffix(".timing")
        for p in (work / "atlases").glob(f"*_{subset_n}_of_{cohort_n}.timing.json")
    )
    names.append(f"all_{subset_n}")  # the first subset_n subjects: neither rule
    names.append(f"{ref}_start2")  # all of them, from another start
    lines = [
        f"The atlas (`symladders atlas` defaults: varifold term, landmark table, start at "
        f"the first subject, `tol` 0.1 mm, at most 10 iterations) of the first {cohort_n} "
        f"subjects' label-image ED meshes, and of subsets of {subset_n} of them with the same "
        "start (so all share its triangulation: vertex i of every atlas comes from vertex i of "
        "the start); then `symladders correspond`, `study --alpha2 100` on the "
        f"{cohort_n} subjects with each atlas, and the planted region's power / Dice "
        "(vertex max-t, FWER 5 %, 1,000 permutations; the region carried onto each atlas "
        "from the generator's mean shape by closest vertex).",
        "",
        "| atlas | iterations (converged) | last moves (mm) | to the atlas of all: per-vertex "
        "RMS (along the normals / along the surface) / mean surface distance (mm) | correspondence ED: median mean surface distance "
        "/ Hausdorff (mm), flagged | power / Dice per transport |",
        "|---|---:|---|---:|---:|---|",
    ]  # fmt: skip
    for name in names:
        t = _timing(work, name)
        if t is None:
            continue
        moves = ", ".join(f"{m:.2f}" for m in (t.get("moves") or [])[-3:]) or "-"
        found = {} if name == ref else atlas_distance(work, name, ref)
        dist = "-" if not found else f"- / {found['surface']:.2f}"
        if "rms" in found:
            dist = "{rms:.2f} ({normal:.2f} / {tangential:.2f}) / {surface:.2f}".format(**found)
        folder = work / "route" / name
        quality = scores = "-"
        if (folder / "analyze.json").is_file():
            r = route(work, name, cohort_n, 1000)
            q = r["quality"]
            quality = (f"{q['mean_surface_distance']:.2f} / {q['hausdorff']:.2f}, "
                       f"{q['flagged']} of {q['meshes']}")  # fmt: skip
            scores = _transports(r["scores"])
        labels = {ref: f"all {cohort_n}", f"all_{subset_n}": f"the first {subset_n}",
                  f"{ref}_start2": f"all {cohort_n}, from the second subject"}  # fmt: skip
        label = labels.get(name, name.replace("0_", " ").replace("_of_", " of ").replace("_", " "))
        lines.append(f"| {label} | {t['n_iter']} ({'yes' if t['converged'] else 'no'}) | "
                     f"{moves} | {dist} | {quality} | {scores} |")  # fmt: skip
    return "\n".join(lines)


def scale_row(work: Path, cohort_n: int, subset: int, n_target: int) -> dict:
    """The per-CPU row: the atlases' cost against the subjects, the route's per subject, the
    extrapolation."""
    runs = {
        n: _timing(work, f"all_{n}") or _timing(work, f"start_{n}") for n in (12, 24, 50, 100, 200)
    }
    runs = {n: t for n, t in runs.items() if t is not None}
    walls, loads = [], []
    for n, t in runs.items():
        later = f", then {np.mean(t['seconds'][1:]):.0f}" if len(t["seconds"]) > 1 else ""
        walls.append(f"{n}: {len(t['seconds'])}, {t['seconds'][0]:.0f}{later} s")
        loads += t["loads"]
    n = np.array(list(runs), dtype=float)
    first = np.array([t["cpu_seconds"][0] for t in runs.values()])
    b, a = np.polyfit(n, first, 1)
    later = [c / t["subjects"] for t in runs.values() for c in t["cpu_seconds"][1:]]
    x = extrapolate(work, n_target, subset, cohort_n)
    st = x["steps"]
    return {
        "subjects: evaluations, wall time of the start's and of each later one (2 workers)":
            "; ".join(walls),
        "core-s per registration: start / later": f"{first.sum() / n.sum():.1f} / "
            f"{np.mean(later):.1f}",
        "core-s of the start's evaluation, fit": f"{a:.0f} + {b:.2f} N",
        "route, core-s per subject": f"mesh {st['mesh']:.2f}, correspond "
            f"{st['correspond']:.1f}, study {st['study']:.1f}, analyze {st['analyze']:.2f} "
            f"(its {cohort_n} subjects' time / {cohort_n}); atlas alignment "
            f"{alignment_cost(work):.1f}",
        f"{n_target:,} subjects, atlas of {subset}": f"atlas {x['atlas']:.0f} core-s; route "
            f"{x['total']:.0f} core-s = {x['hours_on_2_cores']:.2f} h on 2 cores",
        "load": f"{min(loads):.0f}-{max(loads):.0f}",
    }  # fmt: skip


def publish_all(work: Path, cohort_n: int, subset_n: int) -> None:
    if (work / "proxy.json").is_file():
        publish("atlas_subset_proxy", proxy_table(json.loads((work / "proxy.json").read_text())),
                COMMAND)  # fmt: skip
    publish("atlas_subset", subset_table(work, cohort_n, subset_n), COMMAND)
    cells = scale_row(work, cohort_n, 50, 1000)
    publish_rows("atlas_scale", list(cells), cells, COMMAND)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, required=True, help="work folder (kept, resumed)")
    parser.add_argument("--subjects", type=int, default=200)
    parser.add_argument("--sizes", type=int, nargs="+", default=[12, 24])
    parser.add_argument("--evaluation-sizes", type=int, nargs="+", default=[50])
    parser.add_argument("--cohort", type=int, default=24)
    parser.add_argument("--subset-sizes", type=int, nargs="+", default=[12])
    parser.add_argument(
        "--seeds",
        type=int,
        nargs="*",
        default=[0],
        help="seeds of the random subsets (none: the stratified one only)",
    )
    parser.add_argument("--route-subset", type=int, default=12)
    parser.add_argument("--permutations", type=int, default=1000)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument(
        "--parts", nargs="+", default=["proxy", "scale", "subset", "route", "evaluations"]
    )
    parser.add_argument("--publish", action="store_true")
    args = parser.parse_args(argv)
    work = args.work.resolve()
    work.mkdir(parents=True, exist_ok=True)
    mesh = cohort(work, args.subjects)
    print(f"meshing {mesh['subjects']} subjects: {mesh['seconds']:.0f} s (load {mesh['load']})")
    if "scale" in args.parts:
        rows = part_scale(work, args.sizes, args.jobs)
        a, b = fit_growth(rows)
        print(f"seconds per evaluation = {a:.1f} + {b:.2f} N")
    if "proxy" in args.parts:
        _stored(work / "proxy.json", lambda: part_proxy([200, 1000], [12, 25, 50, 100]))
    if "evaluations" in args.parts:
        for row in part_evaluations(work, args.evaluation_sizes, args.jobs):
            print(row)
    if "subset" in args.parts:
        for row in part_subset(work, args.cohort, args.subset_sizes, args.seeds, args.jobs):
            print(row)
    if args.publish:
        publish_all(work, args.cohort, args.route_subset)
    if "route" in args.parts:
        print(mesh_sample(work, args.cohort))
        for atlas in (f"all_{args.cohort}", f"stratified0_{args.route_subset}_of_{args.cohort}"):
            print(atlas, route(work, atlas, args.cohort, args.permutations), flush=True)


if __name__ == "__main__":
    main()
