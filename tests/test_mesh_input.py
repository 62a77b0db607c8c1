"""Meshes from common tools: meshio formats, VTK XML PolyData, --atlas and --cohort tables."""

import csv
import json
import shutil

import meshio
import numpy as np
import pytest

from ladders.study.cli import main
from ladders.study.cohort import (
    MeshFolderError,
    UnusedMeshFilesWarning,
    make_synthetic_cohort,
    read_cohort,
    read_cohort_table,
    write_cohort,
)
from ladders.study.meshes import read_mesh

from .vtp_writer import vtp_bytes

COHORT = make_synthetic_cohort(n_subjects=2, grid=(6, 4), seed=5)
FAST = [
    "--alpha2", "1", "--max-iter", "15", "--n-steps", "5", "--fanning-steps", "3",
    "--jobs", "1", "--no-progress",
]  # fmt: skip


def _meshio_folder(folder, ext, **kwargs):
    """The cohort written by meshio (a .vtk is then an UNSTRUCTURED_GRID, meshio's default)."""
    folder.mkdir(parents=True)
    shapes = {"atlas": COHORT.atlas}
    for s in COHORT.subjects:
        shapes.update({f"{s.name}_ed": s.ed, f"{s.name}_es": s.es})
    for name, v in shapes.items():
        mesh = meshio.Mesh(v, [("triangle", COHORT.faces)], point_data={"strain": v[:, 0]})
        meshio.write(folder / f"{name}{ext}", mesh, **kwargs)
    return folder


def _vtp_folder(folder):
    """The cohort as .vtp files in ParaView's default encoding: appended raw, zlib, UInt64."""
    folder.mkdir(parents=True)
    shapes = {"atlas": COHORT.atlas}
    for s in COHORT.subjects:
        shapes.update({f"{s.name}_ed": s.ed, f"{s.name}_es": s.es})
    for name, v in shapes.items():
        data = vtp_bytes(v, COHORT.faces, fmt="appended", compressor="zlib", points_type="f8")
        (folder / f"{name}.vtp").write_bytes(data)
    return folder


@pytest.mark.parametrize(
    ("ext", "kwargs"),
    [(".vtk", {}), (".vtk", {"binary": False}), (".vtk", {"file_format": "vtk42"}), (".vtu", {}),
     (".ply", {}), (".off", {}), (".obj", {})],
)  # fmt: skip
def test_meshio_written_files_keep_vertex_order(tmp_path, ext, kwargs):
    folder = _meshio_folder(tmp_path / "m", ext, **kwargs)
    if ext == ".vtk":
        assert b"UNSTRUCTURED_GRID" in (folder / "atlas.vtk").read_bytes()[:200]
    back = read_cohort(folder)
    assert back.names == COHORT.names
    np.testing.assert_array_equal(back.faces, COHORT.faces)
    atol = 1e-12 if ext in (".obj", ".off") else 0.0  # text formats with finite digits
    np.testing.assert_allclose(back.atlas, COHORT.atlas, rtol=0, atol=atol)
    np.testing.assert_allclose(back.es, COHORT.es, rtol=0, atol=atol)


@pytest.mark.parametrize("ext", [".vtk", ".vtu", ".vtp", ".ply", ".off", ".obj"])
def test_duplicated_vertices_are_kept(tmp_path, ext):
    """Coincident vertices stay distinct and in place (no reader merges them)."""
    v = np.vstack([COHORT.atlas, COHORT.atlas[:2]])
    f = COHORT.faces.copy()
    f[0] = [len(v) - 2, len(v) - 1, f[0, 2]]  # the copies are used by a face
    path = tmp_path / f"d{ext}"
    if ext == ".vtp":
        path.write_bytes(vtp_bytes(v, f, points_type="f8"))
    else:
        meshio.write(path, meshio.Mesh(v, [("triangle", f)]))
    got_v, got_f = read_mesh(path)
    np.testing.assert_allclose(got_v, v, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(got_f, f)


def test_obj_with_texture_coordinates_and_normals(tmp_path):
    """meshio 5 fails on such OBJ files; trimesh reads them in the file's vertex order."""
    v, f = COHORT.atlas, COHORT.faces
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in v.tolist()] + ["vt 0 0", "vn 0 0 1"]
    lines += [f"f {a}/1/1 {b}/1/1 {c}/1/1" for a, b, c in (f + 1).tolist()]
    (tmp_path / "t.obj").write_text("\n".join(lines) + "\n")
    got_v, got_f = read_mesh(tmp_path / "t.obj")
    np.testing.assert_array_equal(got_v, v)
    np.testing.assert_array_equal(got_f, f)


def test_non_triangle_and_unreadable_files_name_the_file(tmp_path):
    quads = meshio.Mesh(COHORT.atlas, [("triangle", COHORT.faces), ("quad", [[0, 1, 2, 3]])])
    meshio.write(tmp_path / "q.vtu", quads)
    with pytest.raises(
        MeshFolderError, match=r"q\.vtu: expected triangle cells only, found 1 quad"
    ):
        read_mesh(tmp_path / "q.vtu")
    (tmp_path / "bad.vtu").write_text("<VTKFile> not really </VTKFile>")
    with pytest.raises(MeshFolderError, match=r"bad\.vtu: cannot be read as a mesh"):
        read_mesh(tmp_path / "bad.vtu")
    (tmp_path / "bad.ply").write_bytes(b"nonsense")
    with pytest.raises(
        MeshFolderError,
        match=r"bad\.ply: cannot be read as a mesh \(not a PLY file: it starts with b'nonsense'",
    ):
        read_mesh(tmp_path / "bad.ply")
    (tmp_path / "grid.vtk").write_text(
        "# vtk DataFile Version 4.2\nx\nASCII\nDATASET STRUCTURED_POINTS\nDIMENSIONS 2 2 1\n"
        "SPACING 1 1 1\nORIGIN 0 0 0\n"
    )
    with pytest.raises(MeshFolderError, match=r"grid\.vtk: "):
        read_mesh(tmp_path / "grid.vtk")


def _results(out):
    """``{(subject, variant, measure): value}`` of the study's tidy table ``results.csv``."""
    with open(out / "results.csv", newline="") as fh:
        return {
            (r["subject"], r["variant"], r["measure"]): float(r["value"])
            for r in csv.DictReader(fh)
        }


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The study on a folder of legacy polydata .vtk files (the reader of earlier versions)."""
    base = tmp_path_factory.mktemp("ref")
    write_cohort(COHORT, base / "meshes", ext="vtk")
    assert main(["study", "--meshes", str(base / "meshes"), "-o", str(base / "out"), *FAST]) == 0
    return _results(base / "out")


def _same_results(got, ref):
    assert sorted({k[0] for k in got}) == sorted({k[0] for k in ref}) == COHORT.names
    assert sorted(got) == sorted(ref)
    assert {k[1] for k in ref} == {"residual", "no_residual", "fanning"}
    for key, value in ref.items():
        assert got[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key


@pytest.mark.parametrize("kind", ["meshio-vtk", "vtu", "vtp"])
def test_study_on_vtk_vtu_and_vtp_folders(tmp_path, reference, kind):
    if kind == "vtp":
        folder = _vtp_folder(tmp_path / "m")
    else:
        folder = _meshio_folder(tmp_path / "m", ".vtk" if kind == "meshio-vtk" else ".vtu")
    out = tmp_path / "out"
    assert main(["study", "--meshes", str(folder), "-o", str(out), *FAST]) == 0
    _same_results(_results(out), reference)  # same double-precision meshes, same study
    (config_folder,) = (out / "meshes").iterdir()  # one configuration
    tprime = meshio.read(config_folder / COHORT.names[0] / "alpha2_1" / "fanning_Tprime.vtu")
    assert tprime.point_data["las_difference"].shape == (COHORT.n_vertices,)


def test_cohort_table_and_atlas_option(tmp_path, reference, capsys):
    data = tmp_path / "data"
    (data / "scans").mkdir(parents=True)
    rows = ["Subject,ES,ED"]  # any column order and case
    for i, s in enumerate(reversed(COHORT.subjects)):
        meshio.write(
            data / "scans" / f"frame0_{i}.vtu", meshio.Mesh(s.ed, [("triangle", COHORT.faces)])
        )
        (data / "scans" / f"frame9_{i}.vtp").write_bytes(
            vtp_bytes(s.es, COHORT.faces, points_type="f8")
        )
        rows.append(f"{s.name},scans/frame9_{i}.vtp,{data / 'scans' / f'frame0_{i}.vtu'}")
    (data / "cohort.csv").write_text("\n".join(rows) + "\n")
    template = tmp_path / "template.ply"
    meshio.write(template, meshio.Mesh(COHORT.atlas, [("triangle", COHORT.faces)]))
    (data / "scans" / "spare.vtu").write_bytes((data / "scans" / "frame0_0.vtu").read_bytes())
    (data / "volume.msh").write_text("$MeshFormat\n")
    (data / "deep" / "deeper").mkdir(parents=True)
    (data / "deep" / "deeper" / "other.ply").write_bytes(b"ply\n")  # never read nor hashed
    with pytest.warns(
        UnusedMeshFilesWarning,
        match=r"2 mesh file\(s\) not used: .*spare\.vtu \(not in cohort\.csv\); .*volume\.msh \(format",
    ):
        cohort = read_cohort_table(data / "cohort.csv", atlas=template)
    assert cohort.names == [s.name for s in reversed(COHORT.subjects)]  # the table's order
    np.testing.assert_array_equal(cohort.es[0], COHORT.subjects[-1].es)
    out = tmp_path / "out"
    args = ["study", "--cohort", str(data / "cohort.csv"), "--atlas", str(template), "-o", str(out)]
    assert main([*args, *FAST]) == 0
    err = capsys.readouterr().err
    assert "symladders study: warning: 2 mesh file(s) not used" in err and "spare.vtu" in err
    _same_results(_results(out), reference)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["data"]["source"] == "table" and manifest["data"]["atlas"] == str(template)
    # Exactly the files the table names (and the atlas and the table) are hashed: not the
    # unused spare.vtu, volume.msh nor anything deeper under the table's folder.
    named = [
        data / "scans" / f"frame{t}_{i}.{e}" for i in range(2) for t, e in ((0, "vtu"), (9, "vtp"))
    ]
    expected = {str(p.resolve()) for p in (*named, data / "cohort.csv", template)}
    assert set(manifest["input_files"]) == expected
    # Without --atlas the table's folder must hold atlas.<ext>.
    assert main([*args[:3], "-o", str(out), *FAST]) == 2
    assert "no atlas file 'atlas.<ext>' next to the table" in capsys.readouterr().err


def test_atlas_option_on_a_folder_warns_about_the_folder_atlas(tmp_path):
    folder = write_cohort(COHORT, tmp_path / "m", ext="vtu")
    other = tmp_path / "mean.vtu"
    shutil.copy(folder / "atlas.vtu", other)
    with pytest.warns(
        UnusedMeshFilesWarning, match=r"atlas\.vtu \(the atlas given is .*mean\.vtu\)"
    ):
        cohort = read_cohort(folder, atlas=other)
    np.testing.assert_array_equal(cohort.atlas, COHORT.atlas)
    assert main(["study", "--atlas", str(other), "-o", str(tmp_path / "o"), *FAST]) == 2


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ("subject,ed\na,x.vtu\n", r"line 1: missing column 'es'"),
        (
            "subject,ed,es\na,a_ed.vtu,nothing.vtu\n",
            r"line 2, column 'es': .*nothing\.vtu does not exist",
        ),
        (
            "subject,ed,es\na,a_ed.vtu,a_es.vtu\na,a_ed.vtu,a_es.vtu\n",
            r"line 3, column 'subject': a second row for subject 'a' \(the first is line 2\)",
        ),
        ("subject,ed,es\n,a_ed.vtu,a_es.vtu\n", "line 2, column 'subject': empty value"),
        ("subject,ed,es\n../a,a_ed.vtu,a_es.vtu\n", "must not be a path"),
        (
            "subject,ed,es\na,a_ed.txt,a_es.vtu\n",
            r"line 2, column 'ed': .*a_ed\.txt has an unsupported extension",
        ),
        ("subject,ed,es\na,a_ed.vtu\n", "line 2, column 'es': empty value"),
        ("subject,ed,es,site\na,a_ed.vtu,a_es.vtu,x\n", "line 1, column 'site': not used"),
        ("subject,ed,es\n", "no data row"),
    ],
)
def test_cohort_table_errors_name_the_table_and_line(tmp_path, table, message):
    for name in ("atlas", "a_ed", "a_es"):
        meshio.write(
            tmp_path / f"{name}.vtu", meshio.Mesh(COHORT.atlas, [("triangle", COHORT.faces)])
        )
    (tmp_path / "c.csv").write_text(table)
    with pytest.raises(MeshFolderError, match=message) as info:
        read_cohort_table(tmp_path / "c.csv")
    assert "c.csv" in str(info.value)


def test_mismatched_vtp_subject_is_refused_by_the_cli(tmp_path, capsys):
    folder = _vtp_folder(tmp_path / "m")
    small = make_synthetic_cohort(1, grid=(5, 3), seed=0)
    bad = folder / f"{COHORT.names[1]}_es.vtp"
    bad.write_bytes(vtp_bytes(small.atlas, small.faces, fmt="binary", compressor="zlib"))
    assert main(["study", "--meshes", str(folder), "-o", str(tmp_path / "o"), *FAST]) == 2
    err = capsys.readouterr().err
    assert f"{bad} has 16 vertices but the atlas" in err and "25" in err
    (folder / "atlas.vtp").write_bytes(b"<VTKFile type='PolyData'><PolyData>")
    assert main(["study", "--meshes", str(folder), "-o", str(tmp_path / "o"), *FAST]) == 2
    assert "atlas.vtp: not a VTK XML file" in capsys.readouterr().err


def test_readers_are_chosen_by_extension_and_header(tmp_path):
    """One table of formats; the header picks the reader or refuses the file."""
    from ladders.study.meshes import MESH_EXTENSIONS, WRITE_EXTENSIONS
    from ladders.study.meshes.mesh_readers import MESH_FORMATS

    assert MESH_EXTENSIONS == tuple(MESH_FORMATS)
    assert set(WRITE_EXTENSIONS) == set(MESH_EXTENSIONS) - {".vtp"}
    v, f = COHORT.atlas, COHORT.faces
    # An OFF variant meshio does not read (COFF: a colour per vertex) goes to trimesh.
    lines = ["COFF", f"{len(v)} {len(f)} 0"]
    lines += [f"{x!r} {y!r} {z!r} 255 0 0 255" for x, y, z in v.tolist()]
    lines += [f"3 {a} {b} {c}" for a, b, c in f.tolist()]
    (tmp_path / "c.off").write_text("\n".join(lines) + "\n")
    got_v, got_f = read_mesh(tmp_path / "c.off")
    np.testing.assert_array_equal(got_v, v)
    np.testing.assert_array_equal(got_f, f)
    # A file whose header is another format's is refused, naming both.
    meshio.write(tmp_path / "m.vtu", meshio.Mesh(v, [("triangle", f)]))
    (tmp_path / "m.ply").write_bytes((tmp_path / "m.vtu").read_bytes())
    with pytest.raises(MeshFolderError, match=r"m\.ply: .*not a PLY file: it starts with b'<"):
        read_mesh(tmp_path / "m.ply")
    (tmp_path / "m.vtk").write_text("solid x\n")
    with pytest.raises(MeshFolderError, match=r"m\.vtk: .*not a legacy VTK file"):
        read_mesh(tmp_path / "m.vtk")


def test_binary_ply_is_written_through_meshio_in_double(tmp_path):
    from ladders.study.meshes import write_mesh

    path = write_mesh(tmp_path / "a.ply", COHORT.atlas, COHORT.faces)
    header = path.read_bytes().split(b"end_header")[0]
    assert b"format binary_little_endian" in header and b"property double x" in header
    assert b"meshio" in header  # the writer's own comment
    back = meshio.read(path)
    np.testing.assert_array_equal(back.points, COHORT.atlas)
    np.testing.assert_array_equal(back.cells_dict["triangle"], COHORT.faces)
