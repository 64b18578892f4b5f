"""TIFF stacks (``.tif``, ``.tiff``) through tifffile: pages ``(z, y, x)`` read as ``(x, y, z)``; the
spacing from the ImageJ metadata when present."""

import numpy as np

from skelfilter.io.volume import Volume
from skelfilter.io.volume_formats import VolumeFormat
from skelfilter.runtime.extras import need


def _read_tiff(path):
    tifffile = need("tifffile", "TIFF volumes")

    with tifffile.TiffFile(path) as tif:
        pages = tif.asarray()
        meta = dict(tif.imagej_metadata or {})
        page = tif.pages[0]
        resolution = [page.tags.get(name) for name in ("XResolution", "YResolution")]
    spacing = (1.0, 1.0, 1.0)
    if meta:  # ImageJ stores the pixel size as the resolution; other TIFFs hold dots per inch
        xy = [(tag.value[1] / tag.value[0]) if tag is not None and tag.value[0] else 1.0 for tag in resolution]
        spacing = (xy[0], xy[1], float(meta.get("spacing", 1.0)))
    return Volume(np.ascontiguousarray(np.transpose(pages)), np.diag([*spacing, 1.0]), "tiff", meta)


def _write_tiff(tmp, like, data):
    tifffile = need("tifffile", "TIFF volumes")

    spacing = like.spacing
    meta = dict(like.header) if like.format == "tiff" else {}
    meta.pop("min", None), meta.pop("max", None)  # the input's display range, not the output's
    meta.update(spacing=float(spacing[2]), axes="ZYX")
    imagej = data.dtype in (np.uint8, np.uint16, np.float32)
    tifffile.imwrite(tmp, np.ascontiguousarray(np.transpose(data)), imagej=imagej,
                     resolution=(1.0 / spacing[0], 1.0 / spacing[1]),
                     metadata={k: v for k, v in meta.items() if isinstance(v, (int, float, str))} if imagej
                     else None)


FORMAT = VolumeFormat("tiff", (".tif", ".tiff"), _read_tiff, _write_tiff)
