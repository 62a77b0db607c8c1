"""Mesh files of the study's shapes and strain maps, read back through meshio."""

import meshio
import numpy as np
import pytest

from ladders.study.area_strain import area_strain
from ladders.study.cohort import MeshFolderError, make_synthetic_cohort
from ladders.study.meshes import write_point_mesh
from ladders.study.running import StudyConfig, compute_pair, make_space, run_study
from manifolds.residual import ResidualAugmented

COHORT = make_synthetic_cohort(n_subjects=2, grid=(6, 4), seed=3)
CONFIG = StudyConfig.build(alpha2=(1.0,), sigma=20.0, max_iter=15, n_steps=5, fanning_steps=3)
METHODS = ("pole_ladder_residual", "pole_ladder_no_residual", "fanning")


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("meshes_study")
    outcome = run_study(
        CONFIG, COHORT.atlas, COHORT.faces, COHORT.subjects, out, jobs=1, progress=False
    )
    return outcome


def test_every_output_mesh_carries_the_named_point_data(study):
    k = COHORT.n_vertices
    folder = study.output / "meshes" / study.config_id
    atlas = meshio.read(folder / "atlas.vtu")
    np.testing.assert_array_equal(atlas.points, COHORT.atlas)
    np.testing.assert_array_equal(atlas.cells_dict["triangle"], COHORT.faces)
    assert atlas.point_data == {}  # shared by the subjects: no subject's strain (docs)
    for subject, result in zip(COHORT.subjects, study.results, strict=True):
        pair = result.at(1.0)
        las_s = area_strain(subject.ed, subject.es, COHORT.faces)
        for mesh_file in (folder / subject.name).rglob("*.vtu"):
            assert "las_subject" in meshio.read(mesh_file).point_data, mesh_file
        for name in ("S", "S_prime"):
            mesh = meshio.read(folder / subject.name / f"{name}.vtu")
            np.testing.assert_allclose(mesh.point_data["las_subject"], las_s, rtol=0, atol=1e-14)
            np.testing.assert_allclose(mesh.point_data["displacement"], subject.es - subject.ed)
        files = sorted(p.name for p in (folder / subject.name / "alpha2_1").iterdir())
        expected = ["fanning_Tprime.vtu"] + [
            f"pole_ladder_{v}_{s}.vtu"
            for v in ("no_residual", "residual")
            for s in ("M", "Tprime", "sM_Sprime")
        ]
        assert files == sorted(expected)
        for method in METHODS:
            mesh = meshio.read(folder / subject.name / "alpha2_1" / f"{method}_Tprime.vtu")
            assert mesh.points.shape == (k, 3)
            np.testing.assert_array_equal(mesh.cells_dict["triangle"], COHORT.faces)
            data = mesh.point_data
            for name in ("las_subject", "las_transported", "las_difference"):
                assert data[name].shape == (k,)
            assert data["displacement"].shape == (k, 3)
            # The stored strain is that of the written T', and the difference is consistent.
            np.testing.assert_allclose(
                data["las_transported"], area_strain(COHORT.atlas, mesh.points, COHORT.faces),
                rtol=0, atol=1e-12,
            )  # fmt: skip
            las = pair.transport(method).las
            np.testing.assert_allclose(data["las_transported"], las, rtol=0, atol=1e-14)
            np.testing.assert_allclose(data["las_difference"], np.subtract(las, las_s))
            np.testing.assert_allclose(data["displacement"], mesh.points - COHORT.atlas)
            # ASE = L2 norm of the difference map.
            ase = pair.transport(method).ase
            assert np.linalg.norm(data["las_difference"]) == pytest.approx(ase, rel=1e-12)


def test_midpoint_and_reflected_meshes_are_those_of_the_space(study):
    """M = Exp_T(1/2 Log_T S) and s_M(S') of each variant, computed with the library."""
    subject = COHORT.subjects[0]
    space = make_space(CONFIG, COHORT.atlas, 1.0)
    for variant in ("residual", "no_residual"):
        sp = ResidualAugmented(space, use_residuals=variant == "residual")
        m = sp.midpoint(COHORT.atlas, subject.ed)
        expected = {"M": m, "sM_Sprime": sp.symmetry(m, subject.es)}
        for label, points in expected.items():
            path = study.output / "meshes" / study.config_id / subject.name / "alpha2_1"
            mesh = meshio.read(path / f"pole_ladder_{variant}_{label}.vtu")
            np.testing.assert_allclose(mesh.points, points, rtol=0, atol=1e-9)


def test_no_meshes_option_and_legacy_vtk(tmp_path):
    cohort = COHORT.head(1)
    run_study(
        CONFIG, cohort.atlas, cohort.faces, cohort.subjects, tmp_path, progress=False, meshes=False
    )
    assert not (tmp_path / "meshes").exists()
    subject = cohort.subjects[0]
    compute_pair(
        CONFIG, cohort.atlas, cohort.faces, subject, 1.0, tmp_path / "vtk", mesh_format=".vtk"
    )
    paths = sorted((tmp_path / "vtk").rglob("*"))
    assert len([p for p in paths if p.is_file()]) == 1 + 2 + 7
    assert all(p.suffix == ".vtk" for p in paths if p.is_file())
    mesh = meshio.read(tmp_path / "vtk" / cohort.names[0] / "alpha2_1" / "fanning_Tprime.vtk")
    assert mesh.point_data["las_difference"].shape == (cohort.n_vertices,)
    with pytest.raises(ValueError, match="mesh_format: expected one of"):
        compute_pair(CONFIG, cohort.atlas, cohort.faces, subject, 1.0, tmp_path, ".ply")


def test_write_point_mesh_errors(tmp_path):
    with pytest.raises(MeshFolderError, match=r"out\.ply: output format"):
        write_point_mesh(tmp_path / "out.ply", COHORT.atlas, COHORT.faces)
    with pytest.raises(MeshFolderError, match=r"point_data\['x'\]: expected 25 values"):
        write_point_mesh(tmp_path / "o.vtu", COHORT.atlas, COHORT.faces, {"x": np.zeros(3)})
    assert list(tmp_path.iterdir()) == []


def test_cli_no_meshes_then_resume_says_meshes_are_missing(tmp_path, capsys):
    from ladders.study.cli import main

    args = [
        "study", "--subjects", "1", "--vertices", "25", "-o", str(tmp_path), "--alpha2", "1",
        "--max-iter", "10", "--n-steps", "4", "--fanning-steps", "2", "--jobs", "1",
        "--no-progress",
    ]  # fmt: skip
    assert main([*args, "--no-meshes"]) == 0
    assert not (tmp_path / "meshes").exists()
    capsys.readouterr()
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "note: 1 skipped (subject, alpha^2) pair(s) have no mesh files" in out
