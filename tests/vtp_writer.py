"""VTK XML PolyData files built for the tests, following the VTK XML file-format specification.

Arrays are written as ``ascii``, inline ``binary`` (base64) or ``appended``
(raw bytes or base64) data, with a ``UInt32`` or ``UInt64`` header, optionally
compressed in blocks (zlib or lzma) with the header
``[n_blocks, block_size, last_block_size, compressed_size_1, ...]``, in either
byte order. As VTK does, binary headers and data are base64-encoded as two
streams (``two_streams=False`` writes them as one stream, as older writers did).
"""

import base64
import lzma
import zlib

import numpy as np

_COMPRESSORS = {
    "zlib": ("vtkZLibDataCompressor", zlib.compress),
    "lzma": ("vtkLZMADataCompressor", lzma.compress),
}
_NAMES = {"f4": "Float32", "f8": "Float64", "i4": "Int32", "i8": "Int64", "u1": "UInt8"}


class _Encoder:
    def __init__(self, fmt, header, compressor, block_size, endian, two_streams, encoding):
        self.fmt, self.compressor, self.block_size = fmt, compressor, block_size
        self.header = np.dtype(endian + ("u4" if header == "UInt32" else "u8"))
        self.endian, self.two_streams, self.encoding = endian, two_streams, encoding
        self.appended = b""

    def _binary(self, data: bytes) -> tuple[bytes, bytes]:
        if self.compressor is None:
            return np.array([len(data)], self.header).tobytes(), data
        compress = _COMPRESSORS[self.compressor][1]
        blocks = [data[i : i + self.block_size] for i in range(0, len(data), self.block_size)]
        packed = [compress(b) for b in blocks]
        last = len(data) % self.block_size
        head = [len(blocks), self.block_size, last, *(len(p) for p in packed)]
        return np.array(head, self.header).tobytes(), b"".join(packed)

    def array(self, values, code, name, components=1) -> str:
        arr = np.ascontiguousarray(values, dtype=self.endian + code)
        attrs = f'type="{_NAMES[code]}" Name="{name}" NumberOfComponents="{components}"'
        if self.fmt == "ascii":
            text = " ".join(repr(x.item()) for x in arr.ravel())
            return f'<DataArray {attrs} format="ascii">\n{text}\n</DataArray>'
        head, payload = self._binary(arr.tobytes())
        if self.fmt == "binary":
            if self.two_streams:
                text = base64.b64encode(head) + base64.b64encode(payload)
            else:
                text = base64.b64encode(head + payload)
            return f'<DataArray {attrs} format="binary">\n{text.decode()}\n</DataArray>'
        offset = len(self.appended)
        if self.encoding == "raw":
            self.appended += head + payload
        else:
            self.appended += base64.b64encode(head) + base64.b64encode(payload)
        return f'<DataArray {attrs} format="appended" offset="{offset}"/>'


def vtp_bytes(
    vertices,
    faces,
    fmt="binary",
    header="UInt64",
    compressor=None,
    block_size=32768,
    byte_order="LittleEndian",
    two_streams=True,
    encoding="raw",
    points_type="f4",
    version="1.0",
    polygon_sizes=None,
    n_pieces=1,
    strips=0,
) -> bytes:
    """The bytes of a ``.vtp`` file of the mesh ``(vertices, faces)`` (see the module docstring)."""
    endian = "<" if byte_order == "LittleEndian" else ">"
    enc = _Encoder(fmt, header, compressor, block_size, endian, two_streams, encoding)
    v = np.asarray(vertices)
    connectivity = np.asarray(faces).ravel()
    sizes = np.full(len(faces), 3) if polygon_sizes is None else np.asarray(polygon_sizes)
    offsets = np.cumsum(sizes)
    strain = np.linspace(-1.0, 1.0, len(v))
    piece = (
        f'<Piece NumberOfPoints="{len(v)}" NumberOfVerts="0" NumberOfLines="1" '
        f'NumberOfStrips="{strips}" NumberOfPolys="{len(sizes)}">\n'
        f'<PointData Scalars="strain">{enc.array(strain, "f8", "strain")}</PointData>\n<CellData/>\n'
        f"<Points>{enc.array(v, points_type, 'Points', 3)}</Points>\n"
        "<Verts>"
        + enc.array([], "i8", "connectivity")
        + enc.array([], "i8", "offsets")
        + "</Verts>\n"
        "<Lines>"
        + enc.array([0, 1], "i8", "connectivity")
        + enc.array([2], "i8", "offsets")
        + "</Lines>\n"
        f"<Strips/>\n<Polys>{enc.array(connectivity, 'i8', 'connectivity')}"
        f"{enc.array(offsets, 'i8', 'offsets')}</Polys>\n</Piece>\n"
    )
    attrs = f'type="PolyData" version="{version}" byte_order="{byte_order}"'
    if version != "0.1":
        attrs += f' header_type="{header}"'
    if compressor is not None:
        attrs += f' compressor="{_COMPRESSORS[compressor][0]}"'
    text = f'<?xml version="1.0"?>\n<VTKFile {attrs}>\n<PolyData>\n{piece * n_pieces}</PolyData>\n'
    data = text.encode()
    if fmt == "appended":
        data += f'<AppendedData encoding="{encoding}">\n   _'.encode() + enc.appended
        data += b"\n</AppendedData>\n"
    return data + b"</VTKFile>\n"
