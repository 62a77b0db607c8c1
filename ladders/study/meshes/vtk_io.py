"""Legacy VTK polydata (``DATASET POLYDATA``) reader and writer, ASCII and binary, versions 2-5."""

from __future__ import annotations

import re
from itertools import islice
from pathlib import Path

import numpy as np

from ..errors import MeshFolderError

__all__ = ["read_vtk", "write_vtk"]


_VTK_TYPES = {
    "float": "f4", "double": "f8", "int": "i4", "unsigned_int": "u4", "long": "i8",
    "unsigned_long": "u8", "short": "i2", "unsigned_short": "u2", "char": "i1",
    "unsigned_char": "u1", "vtktypeint64": "i8", "vtktypeint32": "i4", "vtkidtype": "i8",
}  # fmt: skip
_CELL_SECTIONS = ("VERTICES", "LINES", "POLYGONS", "TRIANGLE_STRIPS")
_STOP = ("POINT_DATA", "CELL_DATA", "FIELD")  # attributes follow the geometry
_NEXT_SECTION = _CELL_SECTIONS + _STOP
_TOKEN = re.compile(rb"\S+")


class _VtkCursor:
    """Token reader over a legacy VTK file, ASCII or big-endian binary payloads."""

    def __init__(self, data: bytes, binary: bool, path: Path):
        self.data, self.binary, self.path, self.pos = data, binary, path, 0

    def fail(self, what: str):
        raise MeshFolderError(f"{self.path}: {what}")

    def token(self) -> str | None:
        m = _TOKEN.search(self.data, self.pos)
        if m is None:
            return None
        self.pos = m.end()
        return m.group().decode("ascii", "replace")

    def number(self) -> int:
        tok = self.token()
        if tok is None or not tok.isdigit():
            self.fail(f"expected a count, got {tok!r}")
        return int(tok)

    def array(self, n: int, vtk_type: str) -> np.ndarray:
        code = _VTK_TYPES.get(vtk_type.lower())
        if code is None:
            self.fail(f"unsupported VTK data type {vtk_type!r}")
        if self.binary:
            start = self.data.find(b"\n", self.pos) + 1
            end = start + n * int(code[1])
            if start == 0 or end > len(self.data):
                self.fail("binary data ends before the announced number of values")
            self.pos = end
            return np.frombuffer(self.data[start:end], dtype=">" + code).astype(
                np.float64 if code[0] == "f" else np.int64
            )
        found = list(islice(_TOKEN.finditer(self.data, self.pos), n))
        if len(found) < n:
            self.fail(f"expected {n} values, the file ends after {len(found)}")
        if found:
            self.pos = found[-1].end()
        try:
            values = np.array([m.group() for m in found], dtype=np.float64)
        except ValueError:
            self.fail("non-numeric value in a data array")
        if code[0] == "f":
            return values
        if not np.all(values == np.round(values)):
            self.fail("non-integer value in an integer data array")
        return values.astype(np.int64)


def _vtk_cells(cur: _VtkCursor, version: float) -> tuple[np.ndarray, np.ndarray]:
    """Read one cell section; returns the cells' sizes and their concatenated vertex ids."""
    n, size = cur.number(), cur.number()
    if version < 5.0:
        flat = cur.array(size, "int")
        if size == 4 * n and np.all(flat[0::4] == 3):
            return np.full(n, 3), flat.reshape(n, 4)[:, 1:].ravel()
        starts, i = [], 0
        for _ in range(n):
            starts.append(i)
            i += int(flat[i]) + 1
        keep = np.ones(size, dtype=bool)
        keep[starts] = False
        return flat[starts], flat[keep]
    for label, count in (("OFFSETS", n), ("CONNECTIVITY", size)):
        if (cur.token() or "").upper() != label:
            cur.fail(f"expected {label} in a version 5 cell section")
        if label == "OFFSETS":
            offsets = cur.array(count, cur.token() or "")
    return np.diff(offsets), cur.array(size, cur.token() or "")


def read_vtk(path) -> tuple[np.ndarray, np.ndarray]:
    """Read a legacy VTK polydata file (ASCII or binary) of triangles.

    Returns
    -------
    vertices : ndarray, shape (k, 3), float64
    faces : ndarray of int, shape (f, 3)
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise MeshFolderError(f"{path}: cannot be read ({exc})") from exc
    lines = data.split(b"\n", 3)
    head = lines[0].decode("ascii", "replace").strip()
    match = re.match(r"#\s*vtk DataFile Version\s+(\d+(?:\.\d+)?)", head, re.IGNORECASE)
    if match is None or len(lines) < 4:
        raise MeshFolderError(f"{path}: not a legacy VTK file (header {head[:40]!r})")
    version = float(match.group(1))
    fmt = lines[2].decode("ascii", "replace").strip().upper()
    if fmt not in ("ASCII", "BINARY"):
        raise MeshFolderError(f"{path}: third line must be ASCII or BINARY, got {fmt!r}")
    cur = _VtkCursor(data, fmt == "BINARY", path)
    cur.pos = len(lines[0]) + len(lines[1]) + len(lines[2]) + 3
    if (cur.token() or "").upper() != "DATASET" or (cur.token() or "").upper() != "POLYDATA":
        cur.fail("only 'DATASET POLYDATA' is supported")
    points, sizes, ids = None, [], []
    while (tok := cur.token()) is not None:
        key = tok.upper()
        if key == "POINTS":
            n = cur.number()
            points = cur.array(3 * n, cur.token() or "").reshape(n, 3)
        elif key in _CELL_SECTIONS:
            cell_sizes, cell_ids = _vtk_cells(cur, version)
            if key == "TRIANGLE_STRIPS" and len(cell_sizes):
                cur.fail("TRIANGLE_STRIPS are not supported; save the mesh as triangles")
            if key == "POLYGONS":
                sizes.append(cell_sizes)
                ids.append(cell_ids)
        elif key == "METADATA":  # VTK 9 information keys: skip to the next section
            while (nxt := cur.token()) is not None and nxt.upper() not in _NEXT_SECTION:
                pass
            cur.pos -= len(nxt or "")
        elif key in _STOP:
            break
        else:
            cur.fail(f"unexpected section {tok!r}")
    if points is None:
        cur.fail("no POINTS section")
    found = set(np.concatenate(sizes).tolist()) if sizes else set()
    if found != {3}:
        cur.fail(f"expected triangular POLYGONS, got polygon sizes {sorted(found) or 'none'}")
    return points, np.concatenate(ids).astype(np.int64).reshape(-1, 3)


def write_vtk(path, vertices, faces, binary: bool = False) -> Path:
    """Write a triangle mesh as legacy VTK polydata (file version 4.2, double points)."""
    path = Path(path)
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    cells = np.concatenate([np.full((len(f), 1), 3), f], axis=1)
    head = f"# vtk DataFile Version 4.2\nsymladders mesh\n{'BINARY' if binary else 'ASCII'}\n"
    head += f"DATASET POLYDATA\nPOINTS {len(v)} double\n"
    cell_head = f"POLYGONS {len(f)} {cells.size}\n"
    if binary:
        body = v.astype(">f8").tobytes() + b"\n" + cell_head.encode()
        body += cells.astype(">i4").tobytes() + b"\n"
        path.write_bytes(head.encode() + body)
    else:
        pts = "\n".join(" ".join(f"{x:.17g}" for x in row) for row in v)
        tri = "\n".join(" ".join(str(i) for i in row) for row in cells)
        path.write_text(head + pts + "\n" + cell_head + tri + "\n")
    return path
