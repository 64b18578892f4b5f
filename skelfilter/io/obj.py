"""OBJ files: what trimesh's reader does not take made readable (tabs, comments at line ends, concave
polygons), what of its materials is not read said in words, and the file written with its material
library and texture named after it."""

import os
import re

import numpy as np
import trimesh

from skelfilter.io import polygons, text_rows
from skelfilter.io.output_files import write_bytes


def plain_text(text):
    """An OBJ file's ``text`` with tabs as spaces and comments at line ends (``v 0 0 0 # corner``)
    removed, which trimesh's reader does not take; None where it has neither."""
    if b"\t" not in text and not re.search(rb"[^\s#][ \t]*#", text):
        return None
    return re.sub(rb"[ \t]+#[^\r\n]*", b"", text.replace(b"\t", b" "))


_OBJ_POLYGON = re.compile(rb"^[ \t]*f((?:[ \t]+\S+){4,})[ \t]*\r?$", re.M)
_OBJ_VERTEX = re.compile(rb"^[ \t]*v[ \t]+([^\n]*)", re.M)


def split_concave(text):
    """An OBJ file's ``text`` with its concave polygons written as triangles cut inside them
    (`polygons.triangulate`), their texture and normal indices kept: trimesh cuts every polygon as a fan
    from its first corner, across a concave one's notch. None where it has no concave polygon (or
    is malformed: trimesh says how)."""
    found = list(_OBJ_POLYGON.finditer(text))
    if not found:
        return None
    try:
        values, widths = text_rows.numbers(_OBJ_VERTEX.findall(text))
    except ValueError:
        return None
    if (widths < 3).any():
        return None
    vertices = values[(np.cumsum(widths) - widths)[:, None] + np.arange(3)]
    bodies = b"\n".join(match.group(1) for match in found)
    counts = text_rows.words_per_line(bodies, len(found))
    words = np.array(bodies.split(), dtype=object)
    indices = np.array(re.findall(rb"(?<!\S)(-?\d+)", bodies), dtype=np.int64)
    if len(indices) != len(words):
        return None
    if (indices < 0).any():  # relative to the vertices defined before the face
        defined = np.searchsorted([m.start() for m in _OBJ_VERTEX.finditer(text)],
                                  [m.start() for m in found]).repeat(counts)
        indices = np.where(indices < 0, defined + indices + 1, indices)
    indices -= 1
    if indices.min() < 0 or indices.max() >= len(vertices):
        return None
    concave = np.flatnonzero(polygons.is_concave(vertices, counts, indices))
    if not len(concave):
        return None
    starts = np.cumsum(counts) - counts
    taken = polygons.spans(starts[concave], counts[concave])
    triangles, _ = polygons.triangulate(vertices[indices], counts[concave], taken)
    lines = (b"f %s %s %s\n" * len(triangles)) % tuple(words[triangles].ravel())
    cuts = np.concatenate([[0], np.flatnonzero(np.frombuffer(lines, np.uint8) == ord("\n")) + 1])
    sizes = counts[concave] - 2
    first = np.cumsum(sizes) - sizes
    pieces, last = [], 0
    for k, polygon_at in enumerate(concave):  # the concave polygons only, where the text changes
        match = found[polygon_at]
        pieces += [text[last:match.start()], lines[cuts[first[k]]:cuts[first[k] + sizes[k]] - 1]]
        last = match.end()
    return b"".join(pieces + [text[last:]])


def sidecar_problems(path, text):
    """What of an OBJ file's materials is not read, in words: a material library (``mtllib``) or a
    texture (``map_Kd``) that is missing, lies outside the OBJ's folder, or has a name that is not
    UTF-8. trimesh reads the mesh without them and says so only in a debug log."""
    folder = os.path.realpath(os.path.dirname(os.path.abspath(path)))
    problems = []
    for library in re.findall(rb"^[ \t]*mtllib[ \t]+(.+?)[ \t]*\r?$", text, re.M):
        target, problem = _sidecar(folder, library)
        if problem:
            problems.append(f"its material library {problem}; the mesh is read without its materials")
            continue
        with open(target, "rb") as f:
            material = f.read()
        for texture in re.findall(rb"^[ \t]*map_Kd[ \t]+(?:-\S+[ \t]+\S+[ \t]+)*(.+?)[ \t]*\r?$", material, re.M):
            _, problem = _sidecar(os.path.dirname(target), texture)
            if problem:
                problems.append(f"its texture {problem}; the mesh is read without it")
    return problems


def _sidecar(folder, name):
    """The file an OBJ or MTL file names, and what keeps it from being read (None when nothing)."""
    try:
        text = name.decode("utf-8")
    except UnicodeDecodeError:
        return None, f"{name.decode('latin-1')!r} has a name that is not UTF-8"
    target = os.path.realpath(os.path.join(folder, text))
    if os.path.commonpath([folder, target]) != folder:
        return None, f"{text!r} lies outside the file's folder (not read)"
    if not os.path.isfile(target):
        return None, f"{text!r} is missing"
    return target, None


_MTL_PLACEHOLDER, _MATERIAL_PLACEHOLDER = "skelfilter-mtl-3f9c", "skelfilter_material_3f9c"


def save_obj(mesh, path, protect):
    """OBJ with its material library and texture named after it (``out.mtl``, ``out_0.png``), written
    with it in one step: two outputs in one folder never share them, and no file of that name the
    run did not make is replaced (`output_files.check_sidecars`)."""
    from trimesh.exchange.obj import export_obj

    stem = os.path.splitext(os.path.basename(str(path)))[0]
    # trimesh drops the material of a name it cannot encode (a Latin-1 file name, any non-ASCII one
    # under LC_ALL=C) and says so only in a debug log; it gets placeholders, replaced by the real
    # names' bytes, as the file system spells them, once the text is made.
    names = {_MTL_PLACEHOLDER: stem, _MATERIAL_PLACEHOLDER: re.sub(r"\s", "_", stem)}
    if getattr(mesh.visual, "material", None) is not None:
        visual = mesh.visual.copy()
        visual.material.name = _MATERIAL_PLACEHOLDER + "_0"
        mesh = trimesh.Trimesh(mesh.vertices, mesh.faces, visual=visual, process=False)
    text, files = export_obj(mesh, return_texture=True, write_texture=False, mtl_name=f"{_MTL_PLACEHOLDER}.mtl",
                             digits=text_rows.decimal_places(mesh.vertices))
    directory = os.path.dirname(os.path.abspath(str(path)))

    def named(data):
        for placeholder, name in names.items():
            data = data.replace(placeholder.encode(), os.fsencode(name))
        return data

    sidecars = {}
    for name, data in files.items():
        for placeholder, real in names.items():
            name = name.replace(placeholder, real)
        sidecars[os.path.join(directory, name)] = named(data) if name.endswith(".mtl") else data

    write_bytes(path, named(text.encode("utf-8")), protect, sidecars=sidecars)
