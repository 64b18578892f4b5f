"""PLY files read whole and written back whole: every element and property in its own type, the
header's comments, polygons of any size (triangulated inside themselves), Stanford tristrips, face
colours, texture coordinates.

trimesh's reader takes triangles and quads of one size in a binary file, carries face colours of
polygons to the wrong triangles, drops tristrips, comments and unknown properties; here a PLY file is
a `PlyFile` (what the file holds, as it holds it) and a mesh made of it, which carries it
(``mesh.metadata["ply"]``) so that a PLY output of the same vertices writes it back.
"""

import re
from dataclasses import dataclass, field

import numpy as np

from skelfilter.io import polygons, text_rows
from skelfilter.runtime.compiled import njit

_TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4", "uint": "u4", "float": "f4",
          "double": "f8", "int8": "i1", "uint8": "u1", "int16": "i2", "uint16": "u2", "int32": "i4",
          "uint32": "u4", "float32": "f4", "float64": "f8"}
_NAMES = {"i1": "char", "u1": "uchar", "i2": "short", "u2": "ushort", "i4": "int", "u4": "uint", "f4": "float",
          "f8": "double"}
# Vertex properties that hold texture coordinates, as the tools that write PLY name them.
UV_NAMES = (("s", "t"), ("u", "v"), ("texture_u", "texture_v"), ("texture_s", "texture_t"))
COLOUR_NAMES = ("red", "green", "blue", "alpha")


@dataclass
class Property:
    name: str
    type: str  # NumPy's, without byte order: "f4"
    count_type: str = None  # a list's count, NumPy's; None for a single value


@dataclass
class Element:
    name: str
    count: int
    properties: list
    # Property name -> values (n,), or for a list (counts (n,), values (counts.sum(),)).
    data: dict = field(default_factory=dict)


@dataclass
class PlyFile:
    format: str  # "ascii", "binary_little_endian" or "binary_big_endian"
    header_lines: list  # the "comment" and "obj_info" lines, as they are
    elements: list

    def element(self, name):
        return next((e for e in self.elements if e.name == name), None)

    @property
    def texture_file(self):
        found = (re.match(r"comment\s+texturefile\s+(.+?)\s*$", line, re.I) for line in self.header_lines)
        return next((m.group(1) for m in found if m), None)


def read_ply(data):
    """The `PlyFile` of a PLY file's bytes.

    Raises
    ------
    ValueError
        A malformed file, in words.
    """
    if not data.startswith(b"ply"):
        raise ValueError("no 'ply' line at the start")
    end = re.search(rb"end_header[ \t]*\r?\n", data)
    if end is None:
        raise ValueError("no end_header line")
    lines = data[:end.start()].decode("latin-1").splitlines()[1:]
    fmt, notes, elements = None, [], []
    for line in lines:
        words = line.split()
        if not words:
            continue
        if words[0] == "format" and len(words) >= 2:
            fmt = words[1]
        elif words[0] in ("comment", "obj_info"):
            notes.append(line.strip())
        elif words[0] == "element" and len(words) == 3 and words[2].isdigit():
            elements.append(Element(words[1], int(words[2]), []))
        elif words[0] == "property" and elements and len(words) == 3 and words[1] in _TYPES:
            elements[-1].properties.append(Property(words[2], _TYPES[words[1]]))
        elif (words[0] == "property" and elements and len(words) == 5 and words[1] == "list"
              and words[2] in _TYPES and words[3] in _TYPES):
            elements[-1].properties.append(Property(words[4], _TYPES[words[3]], _TYPES[words[2]]))
        else:
            raise ValueError(f"header line {line.strip()!r} is not understood")
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise ValueError(f"format {fmt!r} is none of ascii, binary_little_endian, binary_big_endian")
    body = data[end.end():]
    if fmt == "ascii":
        _read_ascii(elements, body)
    else:
        _read_binary(elements, body, "<" if fmt == "binary_little_endian" else ">")
    return PlyFile(fmt, notes, elements)


def _read_ascii(elements, body):
    """Each element's data from the lines of an ASCII body: one record a line."""
    lines = text_rows.rows(body)
    first = 0
    for element in elements:
        records = lines[first:first + element.count]
        if len(records) < element.count:
            what = {"vertex": "vertices", "face": "faces"}.get(element.name, f"{element.name} records")
            raise ValueError(f"the header declares {element.count} {what}; {len(records)} could be read")
        first += element.count
        values, widths = text_rows.numbers(records)
        position = np.cumsum(widths) - widths
        for prop in element.properties:
            if prop.count_type is None:
                element.data[prop.name] = values[position].astype(prop.type)
                position = position + 1
            else:
                counts = values[position].astype(np.int64)
                element.data[prop.name] = (counts, values[polygons.spans(position + 1, counts)].astype(prop.type))
                position = position + 1 + counts
        if element.count and (position != np.cumsum(widths)).any():
            raise ValueError(f"a {element.name} line holds other than its properties' values")


def _read_binary(elements, body, order):
    """Each element's data from a binary body, records found one after the other where lists make
    their lengths differ (`_record_starts`)."""
    buffer = np.frombuffer(body, dtype=np.uint8)
    offset = 0
    for element in elements:
        sizes = np.array([np.dtype(p.type).itemsize for p in element.properties], dtype=np.int64)
        count_sizes = np.array([np.dtype(p.count_type).itemsize if p.count_type else 0
                                for p in element.properties], dtype=np.int64)
        signed = np.array([p.count_type is not None and p.count_type[0] == "i" for p in element.properties])
        starts = _uniform_starts(buffer, offset, element, sizes, count_sizes, order)
        if starts is None:  # lists of different lengths: the records found one by one
            starts = _record_starts(buffer, offset, element.count, sizes, count_sizes, signed, order == "<")
        if starts[-1] < 0:
            raise ValueError(f"the file ends inside its {element.name} records")
        position = starts[:-1].copy()
        for prop, size, count_size in zip(element.properties, sizes, count_sizes):
            if prop.count_type is None:
                element.data[prop.name] = _gather(buffer, position, size, order + prop.type)
                position += size
            else:
                counts = _gather(buffer, position, count_size, order + prop.count_type).astype(np.int64)
                values = buffer[polygons.spans(position + count_size, counts * size)].view(order + prop.type)
                element.data[prop.name] = (counts, values.astype(prop.type))
                position += count_size + counts * size
        offset = int(starts[-1])
    if offset != len(buffer):
        raise ValueError(f"{len(buffer) - offset} bytes follow the records the header declares")


def _uniform_starts(buffer, offset, element, sizes, count_sizes, order):
    """Where each record begins (and the last ends) when all are the size of the first (every face a
    triangle), or None."""
    at, lists = offset, []  # each list's place in the record, its count's type and its length
    for prop, size, count_size in zip(element.properties, sizes, count_sizes):
        if prop.count_type is None:
            at += size
            continue
        if at + count_size > len(buffer):
            return None
        length = int(buffer[at:at + count_size].view(order + prop.count_type)[0])
        lists.append((at - offset, count_size, order + prop.count_type, length))
        at += count_size + length * size
    starts = offset + np.arange(element.count + 1, dtype=np.int64) * (at - offset)
    if starts[-1] > len(buffer):
        return None
    for place, count_size, count_type, length in lists:
        if (_gather(buffer, starts[:-1] + place, count_size, count_type) != length).any():
            return None
    return starts


def _gather(buffer, positions, size, dtype):
    return buffer[positions[:, None] + np.arange(size)].reshape(-1).view(dtype)


@njit()
def _record_starts(buffer, offset, count, sizes, count_sizes, signed, little):
    """Where each of ``count`` records begins in ``buffer`` from ``offset`` (and where the last ends),
    reading each list's length; the last entry is -1 when the buffer ends first."""
    starts = np.empty(count + 1, dtype=np.int64)
    at = offset
    for record in range(count):
        starts[record] = at
        for p in range(len(sizes)):
            if count_sizes[p] == 0:
                at += sizes[p]
                continue
            if at + count_sizes[p] > len(buffer):
                starts[count] = -1
                return starts
            length = 0
            for b in range(count_sizes[p]):
                byte = buffer[at + (b if little else count_sizes[p] - 1 - b)]
                length |= np.int64(byte) << (8 * b)
            if signed[p] and length >= np.int64(1) << (8 * count_sizes[p] - 1):
                length -= np.int64(1) << (8 * count_sizes[p])
            if length < 0:
                starts[count] = -1
                return starts
            at += count_sizes[p] + length * sizes[p]
    starts[count] = at if at <= len(buffer) else -1
    return starts


def faces_of(ply, vertices):
    """A PLY file's triangles: its faces (polygons triangulated inside themselves) and its tristrips.

    Returns
    -------
    triangles : ndarray (m, 3) of int64
    polygon : ndarray (m,) of int64
        The face each triangle comes from (-1 for a tristrip's).
    """
    found, owner = [np.zeros((0, 3), np.int64)], [np.zeros(0, np.int64)]
    face = ply.element("face")
    indices = _index_list(face)
    if indices is not None:
        counts, corners = indices
        if (counts < 3).any():
            raise ValueError("a face has fewer than 3 corners")
        _check_indices(corners, len(vertices))
        triangles, polygon = polygons.triangulate(vertices, counts, corners)
        found.append(triangles)
        owner.append(polygon)
    strips = _index_list(ply.element("tristrips"))
    if strips is not None:
        triangles = tristrip_triangles(strips[1])
        _check_indices(triangles.reshape(-1), len(vertices))
        found.append(triangles)
        owner.append(np.full(len(triangles), -1))
    return np.concatenate(found), np.concatenate(owner)


def _index_list(element):
    if element is None:
        return None
    return next((element.data[p.name] for p in element.properties
                 if p.count_type and p.name in ("vertex_indices", "vertex_index")), None)


def _check_indices(indices, vertices):
    if len(indices) and (indices.min() < 0 or indices.max() >= vertices):
        bad = indices.min() if indices.min() < 0 else indices.max()
        raise ValueError(f"a face refers to vertex {bad}, and the mesh has {vertices}")


def tristrip_triangles(strip):
    """The triangles of Stanford tristrips (vertex indices, -1 ending a strip): in each strip, every
    vertex from the third on makes a triangle with the two before it, every other one turned so that
    all are wound alike; triangles with a repeated vertex (which join strips) are left out."""
    strip = np.asarray(strip, dtype=np.int64)
    ends = strip < 0
    begins = np.concatenate([[True], ends[:-1]])
    place = np.arange(len(strip)) - np.maximum.accumulate(np.where(begins, np.arange(len(strip)), 0))
    last = np.flatnonzero((place >= 2) & ~ends)
    a, b, c = strip[last - 2], strip[last - 1], strip[last]
    odd = place[last] % 2 == 1
    triangles = np.stack([np.where(odd, b, a), np.where(odd, a, b), c], axis=1)
    whole = (a != b) & (b != c) & (a != c) & (a >= 0) & (b >= 0)
    return triangles[whole]


def vertex_fields(ply, names):
    """The vertex properties ``names`` as columns of one float array, or None unless all are there."""
    vertex = ply.element("vertex")
    if vertex is None or not all(n in vertex.data and not isinstance(vertex.data[n], tuple) for n in names):
        return None
    return np.column_stack([vertex.data[n] for n in names]).astype(np.float64)


def colours(element, prefix=""):
    """An element's RGB(A) colours (``red`` ..., or ``diffuse_red`` ...) as uint8 RGBA, or None."""
    names = [prefix + n for n in COLOUR_NAMES]
    if element is None or not all(n in element.data for n in names[:3]):
        return None
    present = [n for n in names if n in element.data]
    values = np.column_stack([element.data[n] for n in present])
    if values.dtype.kind == "f":
        values = np.round(np.clip(values, 0, 1) * 255)
    values = np.clip(values, 0, 255).astype(np.uint8)
    if values.shape[1] == 3:
        values = np.column_stack([values, np.full(len(values), 255, np.uint8)])
    return values


def ply_bytes(ply):
    """A binary little-endian PLY file of ``ply``'s elements, each property in its own type."""
    header = ["ply", "format binary_little_endian 1.0", *ply.header_lines]
    chunks = []
    for element in ply.elements:
        header.append(f"element {element.name} {element.count}")
        columns = []
        for prop in element.properties:
            if prop.count_type is None:
                header.append(f"property {_NAMES[prop.type]} {prop.name}")
                columns.append(np.asarray(element.data[prop.name]).astype("<" + prop.type).view(np.uint8)
                               .reshape(element.count, -1))
            else:
                header.append(f"property list {_NAMES[prop.count_type]} {_NAMES[prop.type]} {prop.name}")
                columns.append(_list_bytes(*element.data[prop.name], prop))
        chunks.append(_interleave(columns, element.count))
    return ("\n".join(header) + "\nend_header\n").encode("latin-1") + b"".join(chunks)


def _list_bytes(counts, values, prop):
    """A list property's records as (count bytes, value bytes) for `_interleave`."""
    counted = np.asarray(counts).astype("<" + prop.count_type).view(np.uint8).reshape(len(counts), -1)
    items = np.asarray(values).astype("<" + prop.type).view(np.uint8)
    return counted, items, np.asarray(counts, dtype=np.int64) * np.dtype(prop.type).itemsize


def _interleave(columns, count):
    """The bytes of ``count`` records, each the concatenation of its columns' bytes (fixed-size byte
    rows, or lists from `_list_bytes`)."""
    widths = np.zeros(count, dtype=np.int64)
    for column in columns:
        widths += column[0].shape[1] + column[2] if isinstance(column, tuple) else column.shape[1]
    out = np.empty(int(widths.sum()), dtype=np.uint8)
    position = np.cumsum(widths) - widths
    for column in columns:
        fixed = column[0] if isinstance(column, tuple) else column
        out[position[:, None] + np.arange(fixed.shape[1])] = fixed
        position = position + fixed.shape[1]
        if isinstance(column, tuple):
            out[polygons.spans(position, column[2])] = column[1]
            position = position + column[2]
    return out.tobytes()
