"""The atlas at population scale: parallel registrations, an atlas from a subset, reuse."""

import json

import numpy as np
import pytest
import trimesh

import ladders.study.preparation.atlas_registrations as registrations
import ladders.study.preparation.atlas_run as atlas_run
from ladders.study import read_mesh, write_mesh
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from ladders.study.preparation import (
    build_atlas,
    estimate_atlas,
    random_rigid_transform,
    remesh,
)
from ladders.study.preparation.atlas_subset import choose_atlas_subset, shape_descriptor

from .test_preparation import FAST


@pytest.fixture(scope="module")
def cohort():
    return make_synthetic_cohort(4, n_vertices=150, seed=2)


@pytest.fixture(scope="module")
def folder(cohort, tmp_path_factory):
    """The cohort's ED meshes in correspondence, as files."""
    root = tmp_path_factory.mktemp("atlas_meshes")
    for s in cohort.subjects:
        write_mesh(root / f"{s.name}_ed.vtk", s.ed, cohort.faces)
    return root


@pytest.mark.filterwarnings("ignore::manifolds.errors.ConvergenceWarning")
def test_parallel_registrations_give_the_serial_atlas_and_register_once_per_subject(cohort):
    """1 and 2 worker processes give the same atlas to round-off, and the objective of each
    iteration comes from its registrations: one per subject and iterate, none again."""
    rng = np.random.default_rng(0)
    meshes = [remesh(s.ed, cohort.faces, 200) for s in cohort.subjects[:3]]
    meshes = [(random_rigid_transform(rng, 20.0, 5.0).apply(v), f) for v, f in meshes]
    short = FAST.replace(registration=FAST.registration.replace(max_iter=15))
    serial = estimate_atlas(meshes, short, max_iter=1, jobs=1)
    parallel = estimate_atlas(meshes, short, max_iter=1, jobs=2)
    assert not serial.corresponding and serial.n_iter == parallel.n_iter == 1
    scale = np.abs(serial.vertices - serial.vertices.mean(0)).max()
    np.testing.assert_allclose(parallel.vertices, serial.vertices, atol=1e-8 * scale)
    np.testing.assert_allclose(parallel.objectives, serial.objectives, rtol=1e-8)
    assert serial.n_registrations == parallel.n_registrations == 3 * (serial.n_iter + 1)
    moved = np.sqrt(((serial.vertices - meshes[0][0]) ** 2).sum(1).mean())
    assert len(serial.moves) == 1 and abs(serial.moves[0] - moved) < 1e-9 * scale
    assert len(serial.cpu_seconds) == 2 and min(serial.cpu_seconds) > 0


def test_the_weights_make_the_weighted_karcher_mean(cohort):
    """Meshes in correspondence, ``alpha`` small: the atlas with weights ``(1, 0, 0, 0)`` stays
    at the first subject, and with equal weights it is the unweighted atlas."""
    meshes = [(s.ed, cohort.faces) for s in cohort.subjects]
    first = estimate_atlas(meshes, FAST, initial=0, weights=[1.0, 0, 0, 0], max_iter=2)
    assert float(np.sqrt(((first.vertices - meshes[0][0]) ** 2).sum(1).mean())) < 0.05
    equal = estimate_atlas(meshes, FAST, initial="mean", weights=np.full(4, 7.0), max_iter=1)
    plain = estimate_atlas(meshes, FAST, initial="mean", max_iter=1)
    np.testing.assert_allclose(equal.vertices, plain.vertices, atol=1e-10)
    with pytest.raises(ValueError, match="estimate_atlas: weights: expected 4 finite"):
        estimate_atlas(meshes, FAST, weights=[1.0, -1.0, 0.0, 0.0])


def test_the_descriptor_is_rigid_and_triangulation_invariant(cohort):
    sphere = trimesh.creation.icosphere(5, radius=30.0)
    np.testing.assert_allclose(shape_descriptor(sphere.vertices, sphere.faces),
                               np.full(3, 30.0 / np.sqrt(3.0)), rtol=2e-3)  # fmt: skip
    s = cohort.subjects[0]
    v, f = remesh(s.ed, cohort.faces, 600)
    moved = random_rigid_transform(np.random.default_rng(1), 180.0, 50.0).apply(v)
    np.testing.assert_allclose(shape_descriptor(moved, f), shape_descriptor(s.ed, cohort.faces),
                               rtol=0.02)  # fmt: skip


def test_the_stratified_subset_takes_one_subject_per_stratum_weighted_by_its_share():
    """Four separated groups of 5, 10, 20 and 45 subjects: 4 subjects, one of each group,
    each the member nearest its group's centre, weighted by the group's share."""
    rng = np.random.default_rng(3)
    centres = np.array([[0.0, 0.0, 0.0], [10, 0, 0], [0, 10, 0], [0, 0, 10]])
    sizes = [5, 10, 20, 45]
    x = np.vstack([c + 0.3 * rng.standard_normal((k, 3)) for c, k in zip(centres, sizes)])
    group = np.repeat(np.arange(4), sizes)
    sub = choose_atlas_subset(x, 4)
    assert sorted(group[sub.indices]) == [0, 1, 2, 3]
    np.testing.assert_allclose(sub.weights, np.array(sizes) / 80)
    for i in sub.indices:
        members = x[group == group[i]]
        assert np.argmin(((members - members.mean(0)) ** 2).sum(1)) == np.flatnonzero(
            group == group[i]
        ).tolist().index(i)
    again = choose_atlas_subset(x, 4)
    np.testing.assert_array_equal(again.indices, sub.indices)
    # the stratified mean of a one-dimensional spread is near the whole mean; a seeded
    # random draw is reproducible and another seed draws others
    line = rng.uniform(0, 1, (400, 1)) ** 3
    strat = choose_atlas_subset(line, 20)
    assert abs(strat.weights @ line[strat.indices, 0] - line.mean()) < 0.01
    draws = [choose_atlas_subset(line, 20, "random", seed).indices for seed in (0, 0, 1)]
    np.testing.assert_array_equal(draws[0], draws[1])
    assert not np.array_equal(draws[0], draws[2])
    everyone = choose_atlas_subset(line[:5], 20)
    np.testing.assert_array_equal(everyone.indices, np.arange(5))
    with pytest.raises(ValueError, match="rule: expected one of"):
        choose_atlas_subset(line, 3, "kmeans")


def test_a_subset_atlas_names_its_subjects_and_a_rerun_reuses_it(folder, tmp_path, monkeypatch):
    output = tmp_path / "atlas.vtk"
    run = build_atlas(folder, output, FAST, subset=2, max_iter=1)
    record = json.loads(output.with_suffix(".json").read_text())
    subset = record["subset"]
    assert subset["rule"] == "stratified" and subset["n"] == 2 and subset["from"] == 4
    assert record["subjects"] == list(subset["weights"]) and len(record["subjects"]) == 2
    assert abs(sum(subset["weights"].values()) - 1.0) < 1e-12
    assert record["start"] == record["subjects"][0] and not run.reused
    assert record["n_registrations"] == 2 * (record["n_iter"] + 1)

    def refused(*args, **kwargs):
        raise AssertionError("the atlas was estimated again")

    monkeypatch.setattr(atlas_run, "estimate_atlas", refused)
    again = build_atlas(folder, output, FAST, subset=2, max_iter=1, jobs=2)  # jobs: same key
    assert again.reused and again.record["key"] == record["key"]
    np.testing.assert_allclose(again.result.vertices, run.result.vertices, atol=1e-5)
    with pytest.raises(AssertionError, match="estimated again"):
        build_atlas(folder, output, FAST, subset=3, max_iter=1)
    with pytest.raises(AssertionError, match="estimated again"):
        build_atlas(folder, output, FAST, subset=2, max_iter=1, resume=False)
    with pytest.raises(ValueError, match="^subset: choose_atlas_subset: n|^subset: n"):
        build_atlas(folder, output, FAST, subset=0)


def test_an_interruption_during_the_registrations_keeps_the_last_iterate(
    folder, tmp_path, monkeypatch
):
    """Ctrl-C while an iteration's registrations run (in the batch runner): the iterate
    reached before is written with its record, marked interrupted, and is not reused."""
    calls, iterates = [], []
    real = registrations.AtlasLogs.__call__

    def interrupted(self, atlas, targets):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        iterates.append(np.array(atlas))
        return real(self, atlas, targets)

    monkeypatch.setattr(registrations.AtlasLogs, "__call__", interrupted)
    output = tmp_path / "T.vtk"
    with pytest.raises(atlas_run.AtlasInterrupted, match="iteration 1 was written"):
        build_atlas(folder, output, FAST, max_iter=5, tol=0.0)
    record = json.loads(output.with_suffix(".json").read_text())
    assert record["interrupted"] and record["n_iter"] == 1
    np.testing.assert_allclose(read_mesh(output)[0], iterates[1], atol=1e-5)
    assert atlas_run.reusable_atlas(output, record["key"]) is None
