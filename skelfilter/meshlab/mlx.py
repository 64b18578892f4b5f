"""MeshLab filter-script files (.mlx): safe reading with line numbers, and writing.

The format is MeshLab's, as pymeshlab's ``save_filter_script`` writes it::

    <!DOCTYPE FilterScript>
    <FilterScript>
     <filter name="Taubin Smooth">
      <Param name="lambda" type="RichFloat" value="0.5" description="Lambda" tooltip="..."/>
     </filter>
    </FilterScript>

A script comes from the user, so it is read with expat and without a DTD: a DOCTYPE other than
MeshLab's bare ``<!DOCTYPE FilterScript>`` (one with an internal subset, where entities are declared
as in the "billion laughs", or an external reference) is refused where it starts, before anything in
it is declared or expanded; external entities are never fetched; a file over 1 MiB is refused before
it is read. Every element keeps its line, so errors can name it.
"""

import os
import re
from dataclasses import dataclass, field
from xml.parsers import expat
from xml.sax.saxutils import escape

import numpy as np

from skelfilter.errors import InputError
from skelfilter.runtime.extras import need

MAX_SCRIPT_BYTES = 1 << 20

# the order attributes are written in (pymeshlab/Qt writes them in a random order)
_ATTRIBUTE_ORDER = ("name", "type", "value", "min", "max", "x", "y", "z", "r", "g", "b", "a")
_ESCAPES = {'"': "&quot;", "\n": "&#xa;", "\r": "&#xd;", "\t": "&#x9;"}


@dataclass
class ParamElement:
    """One ``<Param>``: its attributes as written, and its line."""

    attrs: dict
    line: int

    @property
    def name(self):
        return self.attrs.get("name", "")


@dataclass
class FilterElement:
    """One ``<filter>``: MeshLab's name of the filter, its line and its parameters."""

    name: str
    line: int
    params: list = field(default_factory=list)


def read_bytes(path):
    """The bytes of a script file, refusing a missing file or one over 1 MiB."""
    path = str(path)
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such filter script")
    size = os.path.getsize(path)
    if size > MAX_SCRIPT_BYTES:
        raise InputError(f"{path}: filter script is {size} bytes, more than the 1 MiB accepted")
    with open(path, "rb") as f:
        data = f.read(MAX_SCRIPT_BYTES + 1)
    if len(data) > MAX_SCRIPT_BYTES:
        raise InputError(f"{path}: filter script is more than the 1 MiB accepted")
    return data


class _Reader:
    """expat handlers building the list of FilterElements."""

    def __init__(self, source):
        self.source = source
        self.parser = expat.ParserCreate()
        self.parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
        self.parser.StartDoctypeDeclHandler = self.doctype
        self.parser.EntityDeclHandler = self.entity
        self.parser.ExternalEntityRefHandler = self.external
        self.parser.StartElementHandler = self.start
        self.parser.EndElementHandler = self.end
        self.depth = 0
        self.root_seen = False
        self.filters = []

    def fail(self, message):
        raise InputError(f"{self.source}:{self.parser.CurrentLineNumber}: {message}")

    def doctype(self, name, system_id, public_id, has_internal_subset):
        if has_internal_subset:
            self.fail("the DOCTYPE declares an internal subset (<!ENTITY> and other declarations), refused")
        if system_id or public_id:
            self.fail(f"the DOCTYPE names an external reference ({system_id or public_id}), refused")
        if name != "FilterScript":
            self.fail(f"DOCTYPE {name!r} is not MeshLab's FilterScript, refused")

    def entity(self, name, *args):
        self.fail(f"the script declares the XML entity {name!r} (<!ENTITY>), refused")

    def external(self, context, base, system_id, public_id):
        self.fail(f"the script refers to an external entity ({system_id}), refused")

    def start(self, tag, attrs):
        self.depth += 1
        line = self.parser.CurrentLineNumber
        if self.depth == 1:
            if tag != "FilterScript" or self.root_seen:
                self.fail(f"root element is <{tag}>, not <FilterScript>")
            self.root_seen = True
        elif self.depth == 2:
            if tag != "filter":
                self.fail(f"<{tag}> inside <FilterScript>; only <filter> elements are supported")
            if not attrs.get("name"):
                self.fail("a <filter> without a name")
            self.filters.append(FilterElement(attrs["name"], line))
        elif self.depth == 3:
            if tag != "Param" or not attrs.get("name"):
                self.fail(f"filter {self.filters[-1].name!r} has an unexpected <{tag}> element "
                          "(only <Param name=...> is supported)")
            self.filters[-1].params.append(ParamElement(dict(attrs), line))
        else:
            self.fail(f"unexpected <{tag}> inside a <Param>")

    def end(self, tag):
        self.depth -= 1


def parse(data, source):
    """The filters of a script's bytes.

    Parameters
    ----------
    data : bytes
        The file's content.
    source : str
        How errors name the script (its path).

    Returns
    -------
    list of FilterElement

    Raises
    ------
    InputError
        Malformed XML, a DOCTYPE with declarations or an external reference, any entity declaration,
        a root other than <FilterScript>, unknown elements, no filter; the message names the line.
    """
    reader = _Reader(source)
    try:
        reader.parser.Parse(data, True)
    except expat.ExpatError as exc:
        raise InputError(f"{source}:{exc.lineno}: malformed filter script XML "
                         f"({expat.ErrorString(exc.code)}, column {exc.offset + 1})") from None
    except (LookupError, ValueError) as exc:  # an encoding Python does not know, or cannot decode
        raise InputError(f"{source}: malformed filter script XML (its encoding: {exc})") from None
    if not reader.filters:
        raise InputError(f"{source}: filter script contains no filters")
    return reader.filters


def _float(attrs, key, where):
    try:
        v = float(attrs[key])
    except KeyError:
        raise InputError(f"{where}: attribute {key!r} missing") from None
    except ValueError:
        raise InputError(f"{where}: {key}={attrs[key]!r} is not a number") from None
    if not np.isfinite(v):
        raise InputError(f"{where}: {key}={attrs[key]!r} is not finite")
    return v


def param_value(attrs, where):
    """Value of one ``<Param>``, as the pymeshlab filter call (and skelfilter's filters) take it.

    RichEnum gives the label of the chosen entry, RichAbsPerc a ``pymeshlab.PercentageValue`` of its
    [min, max] range (MeshLab and pymeshlab read it back as that fraction of the mesh's size).
    """
    kind = attrs.get("type")
    value = attrs.get("value")
    if kind == "RichBool":
        if value is None or value.lower() not in ("true", "false"):
            raise InputError(f"{where}: RichBool value {value!r} is not true/false")
        return value.lower() == "true"
    if kind in ("RichInt", "RichMesh"):
        try:
            return int(value)
        except (TypeError, ValueError):
            raise InputError(f"{where}: {kind} value {value!r} is not an integer") from None
    if kind in ("RichFloat", "RichDynamicFloat"):
        return _float(attrs, "value", where)
    if kind == "RichAbsPerc":
        pymeshlab = need("pymeshlab", "MeshLab's filters")

        v, lo, hi = (_float(attrs, k, where) for k in ("value", "min", "max"))
        if hi > lo and not lo <= v <= hi:
            raise InputError(f"{where}: RichAbsPerc value {attrs['value']} lies outside its range "
                             f"[{attrs['min']}, {attrs['max']}]")
        if hi > lo:
            return pymeshlab.PercentageValue(100.0 * (v - lo) / (hi - lo))
        return pymeshlab.PureValue(v)
    if kind == "RichEnum":
        try:
            index = int(value)
        except (TypeError, ValueError):
            raise InputError(f"{where}: RichEnum value {value!r} is not an integer") from None
        label = attrs.get(f"enum_val{index}")
        if label is None:
            raise InputError(f"{where}: RichEnum value {index} has no enum_val{index}")
        return label
    if kind in ("RichPosition", "RichPoint3f", "RichDirection"):
        return np.array([_float(attrs, k, where) for k in ("x", "y", "z")])
    if kind == "RichMatrix44f":
        return np.array([_float(attrs, f"val{i}", where) for i in range(16)]).reshape(4, 4)
    if kind == "RichColor":
        pymeshlab = need("pymeshlab", "MeshLab's filters")

        channels = [_float(attrs, k, where) for k in "rgba"]
        if not all(0 <= c <= 255 and c == int(c) for c in channels):
            raise InputError(f"{where}: RichColor channels must be integers in [0, 255], got "
                             + ", ".join(f"{k}={attrs[k]}" for k in "rgba"))
        return pymeshlab.Color(*(int(c) for c in channels))
    if kind in ("RichString", "RichOpenFile", "RichSaveFile"):
        if value is None:
            raise InputError(f"{where}: {kind} has no value")
        return value
    raise InputError(f"{where}: parameter type {kind!r} is not supported")


def format_value(value):
    """A value as MeshLab writes it: true/false, integers and shortest round-trip floats."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        text = repr(value)
        return text[:-2] if text.endswith(".0") else text
    return str(value)


def _attribute_key(name):
    if name in _ATTRIBUTE_ORDER:
        return (0, _ATTRIBUTE_ORDER.index(name), 0, "")
    enum = re.fullmatch(r"enum_val(\d+)", name)
    if enum:
        return (1, 0, int(enum.group(1)), "")
    return (2, 0, 0, name)  # description, enum_cardinality, tooltip, ...: alphabetical


def script_text(filters):
    """The text of a script holding ``filters`` (FilterElements), formatted as MeshLab does.

    Attributes are written in a fixed order, so equal scripts give equal files.
    """
    lines = ["<!DOCTYPE FilterScript>", "<FilterScript>"]
    for f in filters:
        head = f' <filter name="{escape(f.name, _ESCAPES)}"'
        if not f.params:
            lines.append(head + "/>")
            continue
        lines.append(head + ">")
        for p in f.params:
            attrs = " ".join(f'{k}="{escape(str(p.attrs[k]), _ESCAPES)}"'
                             for k in sorted(p.attrs, key=_attribute_key))
            lines.append(f"  <Param {attrs}/>")
        lines.append(" </filter>")
    lines.append("</FilterScript>")
    return "\n".join(lines) + "\n"
