"""The volume file formats, one module each, merged in `FORMATS`.

Each module declares ``FORMAT``, a `VolumeFormat`: the format's name, its file suffixes, a reader
(path -> :class:`~skelfilter.io.volume.Volume`) and a writer (temporary path, the input volume whose
grid, affine and header the output keeps, the data). A new format is a new module here and its test:
nothing else names the formats (:mod:`skelfilter.io.formats` builds the table every entry point reads).
"""

import importlib
import pkgutil
from dataclasses import dataclass


@dataclass(frozen=True)
class VolumeFormat:
    name: str
    suffixes: tuple  # lower case, matched at the end of a file name
    read: object  # path -> Volume
    write: object  # (temporary path, like, data) -> None


def _collect():
    found = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        fmt = importlib.import_module(f"{__name__}.{info.name}").FORMAT
        found[fmt.name] = fmt
    return found


FORMATS = _collect()
