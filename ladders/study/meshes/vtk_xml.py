"""Reader of VTK XML PolyData (``.vtp``) triangle meshes, as saved by ParaView, VTK and pyvista.

The file is an XML document (``<VTKFile type="PolyData">``) with one ``<Piece>``
whose ``<Points>`` and ``<Polys>`` (``connectivity``, ``offsets``) data arrays
are stored in one of the format's encodings:

* ``format="ascii"``: numbers as text;
* ``format="binary"``: base64 text, inline;
* ``format="appended"``: in the ``<AppendedData>`` block at the end of the file,
  raw bytes (``encoding="raw"``) or base64 text, at the array's ``offset``.

Binary and appended arrays start with a header of unsigned integers of the
``header_type`` (``UInt32``, the default of file version 0.1, or ``UInt64``):
the byte count of the data, or, when the file names a ``compressor``
(``vtkZLibDataCompressor`` or ``vtkLZMADataCompressor``), the block count, the
uncompressed block size, the size of the last block and the compressed size of
every block, followed by the compressed blocks. Byte order follows the file's
``byte_order``. VTK encodes the header and the data as separate base64 streams;
older writers encode them as one stream: both are read.
"""

from __future__ import annotations

import base64
import binascii
import lzma
import re
import xml.etree.ElementTree as ET
import zlib
from pathlib import Path

import numpy as np

from ..errors import MeshFolderError

__all__ = ["read_vtp"]

_TYPES = {
    "Int8": "i1", "UInt8": "u1", "Int16": "i2", "UInt16": "u2", "Int32": "i4",
    "UInt32": "u4", "Int64": "i8", "UInt64": "u8", "Float32": "f4", "Float64": "f8",
}  # fmt: skip
_DECOMPRESS = {"vtkZLibDataCompressor": zlib.decompress, "vtkLZMADataCompressor": lzma.decompress}


def _b64(text: bytes) -> bytes:
    return base64.b64decode(re.sub(rb"\s+", b"", text), validate=True)


def _b64_chars(n_bytes: int) -> int:
    return 4 * -(-n_bytes // 3)


class _Arrays:
    """Decodes the data arrays of one file (its header type, byte order, compressor)."""

    def __init__(self, path: Path, root: ET.Element, appended: bytes | None, raw: bool):
        self.path, self.appended, self.raw = path, appended, raw
        order = root.get("byte_order", "LittleEndian")
        if order not in ("LittleEndian", "BigEndian"):
            self.fail(f"byte_order must be LittleEndian or BigEndian, got {order!r}")
        self.endian = "<" if order == "LittleEndian" else ">"
        header = root.get("header_type", "UInt32")
        if header not in ("UInt32", "UInt64"):
            self.fail(f"header_type must be UInt32 or UInt64, got {header!r}")
        self.header = np.dtype(self.endian + _TYPES[header])
        compressor = root.get("compressor")
        if compressor is not None and compressor not in _DECOMPRESS:
            self.fail(
                f"compressor {compressor!r} is not supported (supported: {sorted(_DECOMPRESS)}); "
                "save the file with zlib compression or none"
            )
        self.decompress = _DECOMPRESS.get(compressor) if compressor else None

    def fail(self, what: str):
        raise MeshFolderError(f"{self.path}: {what}")

    def read(self, element: ET.Element, label: str) -> np.ndarray:
        """The values of a ``<DataArray>``, flat, in its own dtype."""
        vtype = element.get("type")
        if vtype not in _TYPES:
            self.fail(f"{label}: unsupported data type {vtype!r}")
        dtype = np.dtype(self.endian + _TYPES[vtype])
        fmt = element.get("format", "ascii")
        try:
            if fmt == "ascii":
                return np.array((element.text or "").split(), dtype=dtype.newbyteorder("="))
            if fmt == "binary":
                payload = re.sub(rb"\s+", b"", (element.text or "").encode("ascii"))
                return np.frombuffer(self._base64_block(payload), dtype=dtype)
            if fmt == "appended":
                if self.appended is None:
                    self.fail(f"{label}: format 'appended' but the file has no <AppendedData>")
                offset = int(element.get("offset", "0"))
                block = self._raw_block(offset) if self.raw else self._appended_b64(offset)
                return np.frombuffer(block, dtype=dtype)
        except MeshFolderError:
            raise
        except (ValueError, binascii.Error, zlib.error, lzma.LZMAError) as exc:
            self.fail(f"{label}: corrupt {fmt} data ({exc})")
        self.fail(f"{label}: unknown format {fmt!r} (expected ascii, binary or appended)")

    # -- headers and blocks
    def _header_len(self, first: bytes) -> int:
        """Length in bytes of the header whose first word is in ``first``."""
        w = self.header.itemsize
        if len(first) < w:
            self.fail("data end inside an array header")
        if self.decompress is None:
            return w
        return (3 + int(np.frombuffer(first[:w], self.header)[0])) * w

    def _parse_header(self, head: bytes, head_len: int) -> tuple[int, list[int], int, int]:
        """Stored payload length, compressed block sizes, block size, last block size."""
        if len(head) < head_len:
            self.fail("data end inside an array header")
        values = np.frombuffer(head[:head_len], self.header).astype(np.int64)
        if self.decompress is None:
            return int(values[0]), [], 0, 0
        sizes = values[3:].tolist()
        return int(sum(sizes)), sizes, int(values[1]), int(values[2])

    def _payload(self, data: bytes, length: int, sizes, block: int, last: int) -> bytes:
        if len(data) < length:
            self.fail(f"data end after {len(data)} of the {length} bytes the header announces")
        if self.decompress is None:
            return data[:length]
        out, pos = [], 0
        for i, size in enumerate(sizes):
            chunk = self.decompress(data[pos : pos + size])
            expected = last if (i == len(sizes) - 1 and last) else block
            if len(chunk) != expected:
                self.fail(f"block {i} inflates to {len(chunk)} bytes, the header says {expected}")
            out.append(chunk)
            pos += size
        return b"".join(out)

    def _raw_block(self, offset: int) -> bytes:
        data = self.appended
        if not 0 <= offset < len(data):
            self.fail(f"offset {offset} lies outside the appended data ({len(data)} bytes)")
        head_len = self._header_len(data[offset : offset + self.header.itemsize])
        length, sizes, block, last = self._parse_header(data[offset:], head_len)
        start = offset + head_len
        return self._payload(data[start : start + length], length, sizes, block, last)

    def _appended_b64(self, offset: int) -> bytes:
        text = self.appended.lstrip()
        if not 0 <= offset < len(text):
            self.fail(f"offset {offset} lies outside the appended data ({len(text)} characters)")
        return self._base64_block(text[offset:])

    def _base64_block(self, text: bytes) -> bytes:
        """Header and data from base64 text, encoded as two streams (VTK) or as one."""
        head_len = self._header_len(_b64(text[: _b64_chars(self.header.itemsize)]))
        n_chars = _b64_chars(head_len)
        head = _b64(text[:n_chars])
        length, sizes, block, last = self._parse_header(head, head_len)
        if head_len % 3 and text[n_chars - 1 : n_chars] == b"=":  # two streams
            data = _b64(text[n_chars : n_chars + _b64_chars(length)])
        else:  # one stream (the same text as two when head_len is a multiple of 3)
            data = _b64(text[: _b64_chars(head_len + length)])[head_len:]
        return self._payload(data, length, sizes, block, last)


def _appended(data: bytes, path: Path) -> tuple[bytes, bytes | None, bool]:
    """Split a file into its XML part and its ``<AppendedData>`` payload."""
    match = re.search(rb"<AppendedData\b([^>]*)>", data)
    if match is None:
        return data, None, False
    encoding = re.search(rb'encoding\s*=\s*"([^"]*)"', match.group(1))
    encoding = encoding.group(1).decode() if encoding else "raw"
    if encoding not in ("raw", "base64"):
        raise MeshFolderError(f"{path}: AppendedData encoding must be raw or base64")
    underscore = data.find(b"_", match.end())
    if underscore < 0:
        raise MeshFolderError(f"{path}: AppendedData does not start with '_'")
    return data[: match.start()] + b"</VTKFile>", data[underscore + 1 :], encoding == "raw"


def _array(piece: ET.Element, section: str, name: str | None, arrays: _Arrays) -> np.ndarray:
    node = piece.find(section)
    found = [] if node is None else node.findall("DataArray")
    if name is not None:
        found = [a for a in found if a.get("Name") == name]
    if not found:
        arrays.fail(f"no <{section}> data array{f' {name!r}' if name else ''}")
    return arrays.read(found[0], f"{section} {name or found[0].get('Name', '')}".strip())


def read_vtp(path) -> tuple[np.ndarray, np.ndarray]:
    """Read a triangle mesh from a VTK XML PolyData file (``.vtp``).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    vertices : ndarray, shape (k, 3), float64
    faces : ndarray of int, shape (f, 3)

    Raises
    ------
    MeshFolderError
        Not a VTK XML PolyData file, several pieces, triangle strips or
        non-triangular polygons, an unsupported compressor, or corrupt data;
        the message names the file.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise MeshFolderError(f"{path}: cannot be read ({exc})") from exc
    xml, appended, raw = _appended(data, path)
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as exc:
        raise MeshFolderError(f"{path}: not a VTK XML file ({exc})") from exc
    if root.tag != "VTKFile" or root.get("type") != "PolyData":
        raise MeshFolderError(
            f'{path}: expected a VTK XML PolyData file (<VTKFile type="PolyData">), '
            f"got <{root.tag} type={root.get('type')!r}>"
        )
    arrays = _Arrays(path, root, appended, raw)
    pieces = root.findall("PolyData/Piece")
    if len(pieces) != 1:
        arrays.fail(f"expected one <Piece>, found {len(pieces)}")
    piece = pieces[0]
    n_points = int(piece.get("NumberOfPoints", "0"))
    if int(piece.get("NumberOfStrips", "0")):
        arrays.fail("triangle strips are not supported; save the mesh as triangles")
    if not n_points or not int(piece.get("NumberOfPolys", "0")):
        arrays.fail("no points or no polygons (a triangle mesh needs both)")
    points = _array(piece, "Points", None, arrays)
    if points.size != 3 * n_points:
        arrays.fail(f"Points: expected {3 * n_points} values (3 per point), got {points.size}")
    connectivity = _array(piece, "Polys", "connectivity", arrays).astype(np.int64)
    offsets = _array(piece, "Polys", "offsets", arrays).astype(np.int64)
    n_polys = int(piece.get("NumberOfPolys"))
    if len(offsets) == n_polys + 1 and offsets[0] == 0:
        offsets = offsets[1:]  # offsets with a leading zero
    if len(offsets) != n_polys or offsets[-1] != len(connectivity):
        arrays.fail(
            f"Polys: {len(offsets)} offsets ending at {offsets[-1] if len(offsets) else None} "
            f"for {n_polys} polygons and {len(connectivity)} connectivity entries"
        )
    sizes = set(np.diff(offsets, prepend=0).tolist())
    if sizes != {3}:
        arrays.fail(f"expected triangular polygons, got polygon sizes {sorted(sizes)}")
    faces = connectivity.reshape(-1, 3)
    if faces.min() < 0 or faces.max() >= n_points:
        arrays.fail(f"Polys: vertex indices out of range [0, {n_points})")
    return points.astype(np.float64).reshape(n_points, 3), faces
