"""Reading and writing cohorts of corresponding meshes."""

import numpy as np
import pytest

from ladders.study.cohort import (
    Cohort,
    MeshFolderError,
    Subject,
    make_synthetic_cohort,
    read_cohort,
    write_cohort,
)
from ladders.study.meshes import read_mesh, read_vtk, write_mesh, write_vtk

COHORT = make_synthetic_cohort(n_subjects=3, grid=(9, 5), seed=2)


def assert_same_cohort(a, b, atol=0.0):
    assert a.names == b.names
    np.testing.assert_array_equal(a.faces, b.faces)
    np.testing.assert_allclose(a.atlas, b.atlas, rtol=0, atol=atol)
    np.testing.assert_allclose(a.ed, b.ed, rtol=0, atol=atol)
    np.testing.assert_allclose(a.es, b.es, rtol=0, atol=atol)


@pytest.mark.parametrize("ext", ["ply", "obj", "off", "vtk"])
@pytest.mark.parametrize("layout", ["flat", "subfolders"])
def test_round_trip_indexed_formats(tmp_path, ext, layout):
    write_cohort(COHORT, tmp_path, ext=ext, layout=layout)
    back = read_cohort(tmp_path)
    # Double precision (PLY, VTK) or 17 significant digits (OBJ, OFF).
    assert_same_cohort(back, COHORT, atol=1e-12)
    assert back.source == str(tmp_path)


def test_round_trip_stl(tmp_path):
    """STL keeps float32 triangle soups; vertex order comes back from the shared faces."""
    write_cohort(COHORT, tmp_path, ext="stl")
    back = read_cohort(tmp_path)
    assert_same_cohort(back, COHORT, atol=1e-4)
    np.testing.assert_allclose(back.ed, COHORT.ed.astype(np.float32), rtol=0, atol=1e-12)


def test_stl_vertex_order_by_first_appearance(tmp_path):
    rng = np.random.default_rng(0)
    perm = rng.permutation(COHORT.n_vertices)
    inverse = np.argsort(perm)
    v, f = COHORT.atlas[perm], inverse[COHORT.faces]
    write_mesh(tmp_path / "m.stl", v, f)
    # Alone: vertices are numbered in order of first appearance in the faces.
    merged, merged_faces = read_mesh(tmp_path / "m.stl")
    _, first = np.unique(f.ravel(), return_index=True)
    order = np.argsort(first)
    np.testing.assert_allclose(merged, v[order], atol=1e-4)
    np.testing.assert_allclose(merged[merged_faces], v[f], atol=1e-4)
    # With the triangulation it was written from, the original order is restored.
    indexed, indexed_faces = read_mesh(tmp_path / "m.stl", faces=f)
    np.testing.assert_array_equal(indexed_faces, f)
    np.testing.assert_allclose(indexed, v, atol=1e-4)


def test_vtk_binary_round_trip(tmp_path):
    path = write_vtk(tmp_path / "b.vtk", COHORT.es[1], COHORT.faces, binary=True)
    v, f = read_vtk(path)
    np.testing.assert_array_equal(v, COHORT.es[1])
    np.testing.assert_array_equal(f, COHORT.faces)


def test_vtk_version5_offsets_metadata_and_point_data(tmp_path):
    text = """# vtk DataFile Version 5.1
square
ASCII
DATASET POLYDATA
POINTS 4 float
0 0 0 1 0 0
1 1 0 0 1 0
METADATA
INFORMATION 0

POLYGONS 3 6
OFFSETS vtktypeint64
0 3 6
CONNECTIVITY vtktypeint64
0 1 2 0 2 3
POINT_DATA 4
SCALARS strain float 1
LOOKUP_TABLE default
0 1 2 3
"""
    (tmp_path / "s.vtk").write_text(text)
    v, f = read_vtk(tmp_path / "s.vtk")
    np.testing.assert_array_equal(v, [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    np.testing.assert_array_equal(f, [[0, 1, 2], [0, 2, 3]])


def test_vtk_version5_binary(tmp_path):
    v, f = COHORT.ed[0], COHORT.faces
    offsets = np.arange(0, 3 * len(f) + 1, 3)
    data = b"# vtk DataFile Version 5.1\nlv\nBINARY\nDATASET POLYDATA\n"
    data += f"POINTS {len(v)} float\n".encode() + v.astype(">f4").tobytes() + b"\n"
    data += b"METADATA\nINFORMATION 0\n\n"
    data += f"POLYGONS {len(offsets)} {f.size}\nOFFSETS vtktypeint64\n".encode()
    data += offsets.astype(">i8").tobytes() + b"\nCONNECTIVITY vtktypeint64\n"
    data += f.astype(">i8").tobytes() + b"\n"
    (tmp_path / "b5.vtk").write_bytes(data)
    got_v, got_f = read_vtk(tmp_path / "b5.vtk")
    np.testing.assert_array_equal(got_v, v.astype(np.float32))
    np.testing.assert_array_equal(got_f, f)
    (tmp_path / "cut.vtk").write_bytes(data[: len(data) // 2])
    with pytest.raises(MeshFolderError, match="cut.vtk: binary data ends"):
        read_vtk(tmp_path / "cut.vtk")


def test_vtk_legacy_with_lines_section(tmp_path):
    text = (
        "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n"
        "0 0 0\n1 0 0\n0 1 0\nLINES 1 3\n2 0 1\nPOLYGONS 1 4\n3 0 1 2\n"
    )
    (tmp_path / "t.vtk").write_text(text)
    v, f = read_vtk(tmp_path / "t.vtk")
    assert v.shape == (3, 3)
    np.testing.assert_array_equal(f, [[0, 1, 2]])


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ("DATASET UNSTRUCTURED_GRID\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\n", "POLYDATA"),
        (
            "DATASET POLYDATA\nPOINTS 4 float\n0 0 0 1 0 0 1 1 0 0 1 0\nPOLYGONS 1 5\n4 0 1 2 3\n",
            "triangular",
        ),
        ("DATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0\n", "expected 9 values"),
        ("DATASET POLYDATA\nPOINTS 3 float\n0 0 0 1 0 0 0 1 0\n", "POLYGONS"),
    ],
)
def test_vtk_errors_name_the_file(tmp_path, body, message):
    path = tmp_path / "bad.vtk"
    path.write_text("# vtk DataFile Version 4.2\nx\nASCII\n" + body)
    with pytest.raises(MeshFolderError, match=message) as info:
        read_vtk(path)
    assert "bad.vtk" in str(info.value)


def test_mismatched_vertex_counts_name_both_files(tmp_path):
    write_cohort(COHORT, tmp_path, ext="ply")
    other = make_synthetic_cohort(1, grid=(8, 5), seed=2)
    write_mesh(tmp_path / "synthetic_001_es.ply", other.ed[0], other.faces)
    with pytest.raises(MeshFolderError) as info:
        read_cohort(tmp_path)
    msg = str(info.value)
    assert "synthetic_001_es.ply has 41 vertices" in msg
    assert "atlas.ply" in msg and "46" in msg


def test_faces_differ_from_atlas(tmp_path):
    write_cohort(COHORT, tmp_path, ext="off")
    write_mesh(tmp_path / "synthetic_002_ed.off", COHORT.ed[2], COHORT.faces[::-1])
    with pytest.raises(MeshFolderError, match="synthetic_002_ed.off: faces differ"):
        read_cohort(tmp_path)


def test_unreadable_file(tmp_path):
    write_cohort(COHORT, tmp_path, ext="ply")
    (tmp_path / "synthetic_000_es.ply").write_bytes(b"not a mesh at all")
    with pytest.raises(MeshFolderError, match="synthetic_000_es.ply: cannot be read"):
        read_cohort(tmp_path)
    (tmp_path / "x.obj").write_text("garbage\n")
    with pytest.raises(MeshFolderError, match="x.obj: cannot be read"):
        read_mesh(tmp_path / "x.obj")


def test_missing_es(tmp_path):
    write_cohort(COHORT, tmp_path, ext="vtk")
    (tmp_path / "synthetic_001_es.vtk").unlink()
    with pytest.raises(MeshFolderError, match="subject 'synthetic_001': no ES mesh"):
        read_cohort(tmp_path)


def test_missing_atlas_and_explicit_atlas(tmp_path):
    write_cohort(COHORT, tmp_path / "c", ext="ply")
    (tmp_path / "c" / "atlas.ply").rename(tmp_path / "template.ply")
    with pytest.raises(MeshFolderError, match="no atlas file"):
        read_cohort(tmp_path / "c")
    back = read_cohort(tmp_path / "c", atlas=tmp_path / "template.ply")
    assert_same_cohort(back, COHORT)


def test_layout_errors(tmp_path):
    with pytest.raises(MeshFolderError, match="not a folder"):
        read_cohort(tmp_path / "missing")
    write_cohort(COHORT, tmp_path, ext="ply")
    (tmp_path / "notes.txt").write_text("ignored")
    assert len(read_cohort(tmp_path)) == 3
    write_mesh(tmp_path / "extra.ply", COHORT.atlas, COHORT.faces)
    with pytest.raises(MeshFolderError, match="extra.ply: name does not follow"):
        read_cohort(tmp_path)
    (tmp_path / "extra.ply").unlink()
    write_mesh(tmp_path / "synthetic_000_ed.vtk", COHORT.atlas, COHORT.faces)
    with pytest.raises(MeshFolderError, match="two ED files"):
        read_cohort(tmp_path)
    with pytest.raises(MeshFolderError, match="ext"):
        write_cohort(COHORT, tmp_path / "x", ext="xyz")


def test_natural_subject_order_and_case(tmp_path):
    atlas, faces = COHORT.atlas, COHORT.faces
    subjects = [Subject(n, COHORT.ed[0], COHORT.es[0]) for n in ("p10", "p2", "p1")]
    write_cohort(Cohort(atlas, faces, subjects), tmp_path, ext="ply")
    (tmp_path / "p2_es.ply").rename(tmp_path / "p2_ES.ply")
    assert read_cohort(tmp_path).names == ["p1", "p2", "p10"]


def test_read_mesh_errors(tmp_path):
    with pytest.raises(MeshFolderError, match="no such file"):
        read_mesh(tmp_path / "nothing.ply")
    with pytest.raises(MeshFolderError, match="unsupported extension"):
        read_mesh(tmp_path / "mesh.gltf")
    assert issubclass(MeshFolderError, ValueError)
