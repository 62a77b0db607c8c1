"""Reading VTK XML PolyData (.vtp) in every encoding of the format."""

import itertools

import numpy as np
import pytest

from ladders.study.cohort import MeshFolderError
from ladders.study.cohort.synthetic_lv import make_synthetic_cohort
from ladders.study.meshes.vtk_xml import read_vtp

from .vtp_writer import vtp_bytes

COHORT = make_synthetic_cohort(n_subjects=1, grid=(9, 5), seed=4)
V, F = COHORT.subjects[0].es, COHORT.faces

ENCODINGS = [
    {"fmt": "ascii"},
    *(
        {"fmt": "binary", "header": h, "compressor": c, "two_streams": two}
        for h, c, two in itertools.product(("UInt32", "UInt64"), (None, "zlib"), (True, False))
    ),
    *(
        {"fmt": "appended", "header": h, "compressor": c, "encoding": e}
        for h, c, e in itertools.product(("UInt32", "UInt64"), (None, "zlib"), ("raw", "base64"))
    ),
]


def _id(kw):
    return "-".join(str(v) for v in kw.values())


@pytest.mark.parametrize("kwargs", ENCODINGS, ids=[_id(k) for k in ENCODINGS])
@pytest.mark.parametrize("points_type", ["f4", "f8"])
def test_every_encoding_reads_back_exactly(tmp_path, kwargs, points_type):
    path = tmp_path / "m.vtp"
    path.write_bytes(vtp_bytes(V, F, points_type=points_type, **kwargs))
    v, f = read_vtp(path)
    assert v.dtype == np.float64 and f.dtype == np.int64
    np.testing.assert_array_equal(v, V.astype(points_type))
    np.testing.assert_array_equal(f, F)


@pytest.mark.parametrize("compressor", ["zlib", "lzma"])
@pytest.mark.parametrize("fmt", ["binary", "appended"])
@pytest.mark.parametrize("block_size", [96, 48, 100000])
def test_compressed_blocks(tmp_path, compressor, fmt, block_size):
    """Several blocks with a partial last one (96), whole blocks only (48), one block."""
    assert (V.size * 8) % 96 and (V.size * 8) % 48 == 0  # bytes of the float64 points
    data = vtp_bytes(V, F, fmt=fmt, compressor=compressor, block_size=block_size, points_type="f8")
    (tmp_path / "c.vtp").write_bytes(data)
    v, f = read_vtp(tmp_path / "c.vtp")
    np.testing.assert_array_equal(v, V)
    np.testing.assert_array_equal(f, F)


@pytest.mark.parametrize("fmt", ["ascii", "binary", "appended"])
def test_big_endian_and_version_01(tmp_path, fmt):
    path = tmp_path / "b.vtp"
    path.write_bytes(vtp_bytes(V, F, fmt=fmt, byte_order="BigEndian", points_type="f8"))
    np.testing.assert_array_equal(read_vtp(path)[0], V)
    # Version 0.1 files have no header_type attribute: UInt32 headers.
    path.write_bytes(vtp_bytes(V, F, fmt=fmt, header="UInt32", version="0.1", compressor="zlib"))
    v, f = read_vtp(path)
    np.testing.assert_array_equal(f, F)
    np.testing.assert_allclose(v, V, atol=1e-5)


def test_raw_appended_data_holding_markup_bytes(tmp_path):
    """Raw appended bytes may contain '<', '>' or '_' characters; offsets, not markup, delimit them."""
    v = np.full_like(V, np.frombuffer(b"<_>_<_>_", "<f8")[0])
    v[:, 0] = V[:, 0]
    path = tmp_path / "r.vtp"
    path.write_bytes(vtp_bytes(v, F, fmt="appended", encoding="raw", points_type="f8"))
    assert b"<_>_" in path.read_bytes()
    np.testing.assert_array_equal(read_vtp(path)[0], v)


def _write(tmp_path, data, name="bad.vtp"):
    path = tmp_path / name
    path.write_bytes(data)
    return path


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (
            {"polygon_sizes": [3] * (len(F) - 3) + [4, 4, 1]},
            r"triangular polygons, got polygon sizes \[1, 3, 4\]",
        ),
        ({"strips": 1}, "triangle strips are not supported"),
        ({"n_pieces": 2}, "expected one <Piece>, found 2"),
    ],
)
def test_structure_errors_name_the_file(tmp_path, kwargs, message):
    path = _write(tmp_path, vtp_bytes(V, F, fmt="binary", **kwargs))
    with pytest.raises(MeshFolderError, match=message) as info:
        read_vtp(path)
    assert str(path) in str(info.value)


def test_corrupt_and_foreign_files(tmp_path):
    good = vtp_bytes(V, F, fmt="appended", compressor="zlib", block_size=200)
    cut = _write(tmp_path, good[: len(good) - 300], "cut.vtp")
    with pytest.raises(MeshFolderError, match="cut.vtp: .*(end|corrupt)"):
        read_vtp(cut)
    raw = vtp_bytes(V, F, fmt="appended")
    with pytest.raises(MeshFolderError, match="trunc.vtp: .*data end after"):
        read_vtp(_write(tmp_path, raw[: raw.rindex(b"\n</AppendedData>") - 10], "trunc.vtp"))
    lz4 = good.replace(b"vtkZLibDataCompressor", b"vtkLZ4DataCompressor")
    with pytest.raises(MeshFolderError, match="lz4.vtp: compressor 'vtkLZ4DataCompressor'"):
        read_vtp(_write(tmp_path, lz4, "lz4.vtp"))
    grid = vtp_bytes(V, F, fmt="ascii").replace(b'type="PolyData"', b'type="UnstructuredGrid"')
    with pytest.raises(MeshFolderError, match="grid.vtp: expected a VTK XML PolyData file"):
        read_vtp(_write(tmp_path, grid, "grid.vtp"))
    with pytest.raises(MeshFolderError, match="junk.vtp: not a VTK XML file"):
        read_vtp(_write(tmp_path, b"solid x\nendsolid\n", "junk.vtp"))
    tag = b'Name="Points" NumberOfComponents="3" format="binary">\n'
    b64 = vtp_bytes(V, F, fmt="binary").replace(tag, tag + b"#!")
    with pytest.raises(MeshFolderError, match="b64.vtp: .*corrupt binary data"):
        read_vtp(_write(tmp_path, b64, "b64.vtp"))
    text = vtp_bytes(V, F, fmt="ascii").replace(b"0 1 2", b"0 one 2", 1)
    with pytest.raises(MeshFolderError, match="text.vtp: .*corrupt ascii data"):
        read_vtp(_write(tmp_path, text, "text.vtp"))
    with pytest.raises(MeshFolderError, match="cannot be read"):
        read_vtp(tmp_path / "missing.vtp")
