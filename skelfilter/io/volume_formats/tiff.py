"""TIFF stacks (``.tif``, ``.tiff``) through tifffile: pages ``(z, y, x)`` read as ``(x, y, z)``; the
spacing from the ImageJ metadata or the OME-XML (``PhysicalSizeX/Y/Z``, in micrometres) when present,
and written back the same way."""

import xml.etree.ElementTree as ElementTree

import numpy as np

from skelfilter.io.volume import Volume
from skelfilter.io.volume_formats import VolumeFormat
from skelfilter.runtime.extras import need


def _read_tiff(path):
    tifffile = need("tifffile", "TIFF volumes")

    with tifffile.TiffFile(path) as tif:
        pages = tif.asarray()
        meta = dict(tif.imagej_metadata or {})
        ome = _ome_sizes(tif.ome_metadata) if tif.is_ome else None
        page = tif.pages[0]
        resolution = [page.tags.get(name) for name in ("XResolution", "YResolution")]
    spacing = (1.0, 1.0, 1.0)
    if ome:
        spacing, meta = ome, {"ome": True}
    elif meta:  # ImageJ stores the pixel size as the resolution; other TIFFs hold dots per inch
        xy = [(tag.value[1] / tag.value[0]) if tag is not None and tag.value[0] else 1.0 for tag in resolution]
        spacing = (xy[0], xy[1], float(meta.get("spacing", 1.0)))
    return Volume(np.ascontiguousarray(np.transpose(pages)), np.diag([*spacing, 1.0]), "tiff", meta)


# OME's length units in micrometres, the unit its sizes default to.
_OME_MICROMETRES = {"nm": 1e-3, "Å": 1e-4, "µm": 1.0, "um": 1.0, "mm": 1e3, "cm": 1e4, "m": 1e6}


def _ome_sizes(xml):
    """The voxel size (x, y, z) in micrometres an OME-XML text states (1 where it states none), or
    None when it states none at all or in a unit that is no length."""
    pixels = next((e for e in ElementTree.fromstring(xml).iter() if e.tag.rsplit("}", 1)[-1] == "Pixels"), None)
    if pixels is None or not any(f"PhysicalSize{axis}" in pixels.attrib for axis in "XYZ"):
        return None
    units = [_OME_MICROMETRES.get(pixels.get(f"PhysicalSize{axis}Unit", "µm")) for axis in "XYZ"]
    if None in units:
        return None
    return tuple(float(pixels.get(f"PhysicalSize{axis}", 1.0)) * unit for axis, unit in zip("XYZ", units))


def _write_tiff(tmp, like, data):
    tifffile = need("tifffile", "TIFF volumes")

    spacing = like.spacing
    if like.format == "tiff" and (like.header or {}).get("ome"):
        sizes = {f"PhysicalSize{axis}": float(size) for axis, size in zip("XYZ", spacing)}
        units = {f"PhysicalSize{axis}Unit": "µm" for axis in "XYZ"}
        tifffile.imwrite(tmp, np.ascontiguousarray(np.transpose(data)), ome=True,
                         metadata={"axes": "ZYX", **sizes, **units})
        return
    meta = dict(like.header) if like.format == "tiff" else {}
    meta.pop("min", None), meta.pop("max", None)  # the input's display range, not the output's
    meta.update(spacing=float(spacing[2]), axes="ZYX")
    imagej = data.dtype in (np.uint8, np.uint16, np.float32)
    tifffile.imwrite(tmp, np.ascontiguousarray(np.transpose(data)), imagej=imagej,
                     resolution=(1.0 / spacing[0], 1.0 / spacing[1]),
                     metadata={k: v for k, v in meta.items() if isinstance(v, (int, float, str))} if imagej
                     else None)


FORMAT = VolumeFormat("tiff", (".tif", ".tiff"), _read_tiff, _write_tiff)
