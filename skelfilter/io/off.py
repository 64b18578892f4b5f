"""OFF files (Geomview's ``[ST][C][N]OFF``): polygons of any number of corners, triangulated inside
themselves (:mod:`skelfilter.io.polygons`), and the colours of vertices (COFF) and faces kept; written
back with them.

trimesh's reader takes triangles and quads only, and drops colours.
"""

import re

import numpy as np
import trimesh

from skelfilter.io import polygons, text_rows


def load_off(data):
    """A ``trimesh.Trimesh`` of an OFF file's bytes, with its vertex or face colours.

    Returns
    -------
    mesh : trimesh.Trimesh
    dropped : list of str
        What of the file the mesh does not hold (texture coordinates, normals), in words.

    Raises
    ------
    ValueError
        A malformed file, in words.
    """
    lines = text_rows.rows(re.sub(rb"#[^\n]*", b"", data))
    keyword = re.fullmatch(rb"\s*(ST)?(C)?(N)?(4)?(n)?OFF(\s.*)?", lines[0] if lines else b"", re.S)
    if keyword is None:
        raise ValueError("no OFF keyword at the start")
    texture, colour, normal, four, dimension, rest = keyword.groups()
    if four or dimension:
        raise ValueError("an OFF file of points in other than 3 dimensions")
    header = lines[1:]
    if rest and rest.strip():  # the counts on the keyword's line
        header = [rest, *header]
    if not header:
        raise ValueError("no vertex and face counts")
    counts = header[0].split()
    if len(counts) < 2 or not all(c.isdigit() for c in counts[:2]):
        line = header[0].decode("latin-1").strip()
        raise ValueError(f"the counts line {line!r} is not numbers of vertices and faces")
    n_vertices, n_faces = int(counts[0]), int(counts[1])
    vertex_lines, face_lines = header[1:1 + n_vertices], header[1 + n_vertices:1 + n_vertices + n_faces]
    if len(vertex_lines) < n_vertices or len(face_lines) < n_faces:
        raise ValueError(f"the header declares {n_vertices} vertices and {n_faces} faces; the file holds "
                         f"{min(len(vertex_lines), n_vertices)} and {len(face_lines)}")
    values, widths = text_rows.numbers(vertex_lines)
    if len(set(widths.tolist())) > 1:
        raise ValueError("its vertex lines hold different numbers of values")
    table = values.reshape(n_vertices, -1)
    layout = 3 + 3 * bool(normal) + 2 * bool(texture)
    if table.shape[1] < layout + (3 if colour else 0):
        raise ValueError(f"its vertex lines hold {table.shape[1]} values, {keyword.group(0).split()[0].decode()} "
                         f"needs {layout + (3 if colour else 0)}")
    vertex_colours = _colours(table[:, 3 + 3 * bool(normal):table.shape[1] - 2 * bool(texture)]) if colour else None
    values, widths = text_rows.numbers(face_lines)
    starts = np.cumsum(widths) - widths
    sizes = values[starts].astype(np.int64) if n_faces else np.zeros(0, np.int64)
    if (sizes < 3).any() or (sizes + 1 > widths).any():
        raise ValueError("a face line has fewer than 3 corners, or fewer indices than it counts")
    corners = values[polygons.spans(starts + 1, sizes)]
    if (corners != np.round(corners)).any() or (corners < 0).any() or (corners >= n_vertices).any():
        raise ValueError("a face refers to a vertex the file does not have")
    triangles, polygon = polygons.triangulate(table[:, :3], sizes, corners.astype(np.int64))
    extra = widths - 1 - sizes
    face_colours = None
    if n_faces and (extra >= 3).all() and len(set(extra.tolist())) == 1:
        face_colours = _colours(values[polygons.spans(starts + 1 + sizes, extra)].reshape(n_faces, -1))[polygon]
    visual = trimesh.visual.ColorVisuals(vertex_colors=vertex_colours, face_colors=face_colours)
    mesh = trimesh.Trimesh(table[:, :3], triangles, visual=visual, process=False)
    dropped = [name for name, present in (("texture coordinates", texture), ("normals", normal)) if present]
    if n_faces and (extra > 0).any() and face_colours is None:
        dropped.append("face colours given by colour map index")
    return mesh, dropped


def _colours(values):
    """RGB(A) colours as uint8: values of 0-255, or of 0-1 where none is above 1."""
    scale = 255.0 if values.size and values.max() <= 1.0 else 1.0
    colours = np.clip(np.round(values * scale), 0, 255).astype(np.uint8)
    if colours.shape[1] == 3:
        colours = np.column_stack([colours, np.full(len(colours), 255, np.uint8)])
    return colours[:, :4]


def off_text(mesh, digits):
    """An OFF file's text for ``mesh`` (``digits`` decimal places): COFF with its vertex colours, its face
    colours after each face."""
    kind = getattr(mesh.visual, "kind", None)
    vertices = [np.asarray(mesh.vertices, dtype=np.float64)]
    formats = [f"%.{digits}f"] * 3
    if kind == "vertex":
        vertices.append(np.asarray(mesh.visual.vertex_colors, dtype=np.uint8))
        formats += ["%d"] * 4
    faces = [np.full((len(mesh.faces), 1), 3), np.asarray(mesh.faces)]
    if kind == "face":
        faces.append(np.asarray(mesh.visual.face_colors, dtype=np.uint8))
    faces = np.concatenate(faces, axis=1)
    keyword = "COFF" if kind == "vertex" else "OFF"
    return (f"{keyword}\n{len(mesh.vertices)} {len(mesh.faces)} 0\n"
            f"{_table(np.concatenate(vertices, axis=1), formats)}{_table(faces, ['%d'] * faces.shape[1])}")


def _table(values, formats):
    """Rows of ``values`` written with one printf format per column, each row ended by a newline."""
    row = " ".join(formats) + "\n"
    return (row * len(values)) % tuple(np.asarray(values, dtype=object).ravel())
