"""Volume files in and out: NIfTI (nibabel), NRRD (pynrrd), TIFF stacks (tifffile) and NumPy ``.npy``.

A volume is read as an array indexed ``(i, j, k)`` and the affine that takes an index to the
scanner's world coordinates (millimetres for NIfTI and NRRD): ``world = affine @ (i, j, k, 1)``.
A TIFF stack, stored as pages ``(z, y, x)``, is read as ``(x, y, z)``; its spacing comes from the
ImageJ metadata when present. A ``.npy`` file has no geometry: unit spacing, unless given.

What the denoiser works on is a binary mask chosen from the data (`select_mask`): the set voxels of
a mask, one label of a label map, or a grey-level image above an iso level. The output keeps the
input's format, grid, header and affine (`save_volume`), and a label map keeps every other label
(`merge_label`).
"""

import os
from dataclasses import dataclass

import numpy as np

from skelfilter.errors import InputError, ResourceError
from skelfilter.io.output_files import atomic_write
from skelfilter.runtime.extras import MissingExtra, need
from skelfilter.runtime.memory import available_bytes

# Suffix -> format; ``.nii.gz`` is matched before ``.gz`` would be.
VOLUME_SUFFIXES = {".nii.gz": "nifti", ".nii": "nifti", ".nrrd": "nrrd", ".tif": "tiff", ".tiff": "tiff",
                   ".npy": "npy"}


@dataclass
class Volume:
    """A volume file's contents.

    Attributes
    ----------
    data : ndarray, 3-D
        The voxel values, indexed ``(i, j, k)``.
    affine : ndarray, shape (4, 4)
        Index to world coordinates.
    format : str
        ``nifti``, ``nrrd``, ``tiff`` or ``npy``.
    header : object
        The format's own header (nibabel header, NRRD dict, ImageJ metadata), written back as it is.
    """

    data: np.ndarray
    affine: np.ndarray
    format: str
    header: object = None

    @property
    def spacing(self):
        """Voxel size along i, j, k in world units (the lengths of the affine's columns)."""
        return np.linalg.norm(self.affine[:3, :3], axis=0)


def volume_format(path):
    """The volume format of ``path`` from its suffix, or None for anything else."""
    name = str(path).lower()
    return next((fmt for suffix, fmt in VOLUME_SUFFIXES.items() if name.endswith(suffix)), None)


def load_volume(path, spacing=None):
    """Read a volume file.

    Parameters
    ----------
    path : str
    spacing : sequence of 3 floats, optional
        Voxel size replacing the file's (the only one a ``.npy`` file has).

    Raises
    ------
    InputError
        A missing, unreadable or malformed file, or data that is not 3-D.
    """
    path = str(path)
    fmt = volume_format(path)
    if fmt is None:
        raise InputError(f"{path}: not a volume file (use {', '.join(VOLUME_SUFFIXES)})")
    if os.path.isdir(path):
        raise InputError(f"{path}: is a folder, not a volume file")
    if not os.path.isfile(path):
        raise InputError(f"{path}: no such file")
    try:
        volume = _READERS[fmt](path)
    except (InputError, ResourceError, MissingExtra):  # a missing reader is no malformed file
        raise
    except MemoryError:
        raise ResourceError(f"{path}: the volume does not fit in the memory available") from None
    except Exception as exc:  # each library raises its own kinds on corrupt files
        raise InputError(f"{path}: malformed {fmt.upper()} file ({str(exc) or type(exc).__name__})") from None
    if volume.data.ndim == 4 and volume.data.shape[3] == 1:
        volume.data = volume.data[..., 0]
    if volume.data.ndim != 3:
        raise InputError(f"{path}: a volume must be 3-D, got shape {volume.data.shape}")
    if spacing is not None:  # checked by params.VolumeParams
        volume.affine = volume.affine.copy()
        volume.affine[:3, :3] = volume.affine[:3, :3] / volume.spacing * np.asarray(spacing, dtype=float)
    if not (np.isfinite(volume.affine).all() and abs(np.linalg.det(volume.affine[:3, :3])) > 0):
        raise InputError(f"{path}: the voxel-to-world matrix is singular or not finite")
    return volume


def _check_claimed_size(path, shape, itemsize, stored=None):
    """Refuse a header whose volume the file cannot hold (``stored``: the bytes it has for the data,
    when it is not compressed) or the memory cannot, before the data is read."""
    shape = tuple(int(n) for n in shape)
    if any(n < 0 for n in shape):
        raise InputError(f"{path}: malformed header (negative size {shape})")
    need_bytes = int(np.prod(shape, dtype=object)) * int(itemsize)
    size = "x".join(map(str, shape))
    if stored is not None and need_bytes > stored:
        raise InputError(f"{path}: malformed file (the header claims a {size} volume of {itemsize}-byte values, "
                         f"{need_bytes} bytes of data; the file holds {max(stored, 0)})")
    have = available_bytes()
    if need_bytes > have:
        raise ResourceError(f"{path}: the header claims a {size} volume of {itemsize}-byte values, "
                            f"{need_bytes / 2**30:.1f} GiB, but only {have / 2**30:.1f} GiB is available")


def _read_nifti(path):
    nibabel = need("nibabel", "NIfTI volumes")

    image = nibabel.load(path)
    compressed = path.lower().endswith(".gz")
    offset = int(image.dataobj.offset) if hasattr(image.dataobj, "offset") else 0
    _check_claimed_size(path, image.shape, image.get_data_dtype().itemsize,
                        None if compressed else os.path.getsize(path) - offset)
    return Volume(np.asanyarray(image.dataobj), np.asarray(image.affine, dtype=float), "nifti", image.header)


# NRRD spaces whose first two axes point the other way from NIfTI's right-anterior-superior.
_LPS_SPACES = ("left-posterior-superior", "lps")
_RAS_SPACES = ("right-anterior-superior", "ras")


def _read_nrrd(path):
    nrrd = need("nrrd", "NRRD volumes")

    header = nrrd.read_header(path)
    _check_data_file(path, header)
    if "sizes" in header:
        _check_claimed_size(path, header["sizes"], _nrrd_itemsize(nrrd, header))
    data, header = nrrd.read(path)
    space = str(header.get("space", "")).lower()
    if space and space not in _LPS_SPACES + _RAS_SPACES:
        raise InputError(f"{path}: NRRD space {header['space']!r} is not supported (use "
                         "right-anterior-superior or left-posterior-superior)")
    affine = np.eye(4)
    directions = header.get("space directions")
    if directions is not None:
        rows = [d for d in np.asarray(directions, dtype=object) if d is not None and np.all(np.isfinite(
            np.asarray(d, dtype=float)))]
        affine[:3, :3] = np.asarray(rows, dtype=float).T
    elif "spacings" in header:
        affine[:3, :3] = np.diag(np.asarray(header["spacings"], dtype=float)[:3])
    if "space origin" in header:
        affine[:3, 3] = np.asarray(header["space origin"], dtype=float)
    if space in _LPS_SPACES:  # world coordinates are RAS, as NIfTI's, whatever the file's convention
        affine = np.diag([-1.0, -1.0, 1.0, 1.0]) @ affine
    return Volume(data, affine, "nrrd", header)


def _check_data_file(path, header):
    """A detached NRRD header's data file is read only beside the header (its folder or below), so
    that an input file cannot pull in any file the user can read."""
    name = header.get("datafile", header.get("data file"))
    if name is None:
        return
    folder = os.path.realpath(os.path.dirname(os.path.abspath(path)))
    target = os.path.realpath(os.path.join(folder, str(name)))
    if os.path.commonpath([folder, target]) != folder:
        raise InputError(f"{path}: its data file {str(name)!r} lies outside the header's folder; detached data "
                         "is read only from the header's folder or below")
    if not os.path.isfile(target):
        raise InputError(f"{path}: its data file {str(name)!r} is missing")


def _nrrd_itemsize(nrrd, header):
    try:
        return np.dtype(nrrd.reader._determine_datatype(header)).itemsize
    except Exception:  # an unknown type: the reader says so next
        return 1


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


def _read_npy(path):
    return Volume(np.load(path, allow_pickle=False), np.eye(4), "npy", None)


_READERS = {"nifti": _read_nifti, "nrrd": _read_nrrd, "tiff": _read_tiff, "npy": _read_npy}


def select_mask(data, label=None, iso=None):
    """The binary shape to denoise: ``data == label``, ``data >= iso``, or the nonzero voxels; NaN
    voxels are never part of it.

    Raises
    ------
    InputError
        Non-numeric data, several values and neither ``label`` nor ``iso``, or an empty selection.
    """
    if not (np.issubdtype(data.dtype, np.number) or data.dtype == bool):
        raise InputError(f"volume data of type {data.dtype} is not numeric")
    if label is not None:
        mask, empty = data == label, f"label {label} selects no voxel"
    elif iso is not None:
        mask, empty = data >= iso, f"no voxel is at or above the iso level {iso:g}"
    else:
        values = np.unique(data)
        finite = values[~np.isnan(values)] if np.issubdtype(values.dtype, np.floating) else values
        if finite.size > 2:
            also = " and NaN voxels" if finite.size < values.size else ""
            raise InputError(f"the volume holds {finite.size} values{also}, not a mask: choose the shape with "
                             "`label` N (a label map) or `iso` LEVEL (a grey-level image)")
        mask, empty = data != 0, "no voxel is set"
        if finite.size < values.size:
            mask &= ~np.isnan(data)
    if not mask.any():
        raise InputError(f"the volume is empty: {empty}")
    return mask


def merge_label(labels, before, after, label):
    """``labels`` with label ``label`` changed from ``before`` to ``after``: removed voxels become 0,
    added voxels take the label only where there was background; every other label stays."""
    out = labels.copy()
    out[before & ~after] = 0
    out[after & ~before & (labels == 0)] = label
    return out


def save_volume(path, like, data, protect=()):
    """Write ``data`` (on ``like``'s grid) to ``path`` in ``path``'s format, atomically, with
    ``like``'s affine and header where the format has them."""
    fmt = volume_format(path)
    if fmt is None:
        raise InputError(f"{path}: not a volume file (use {', '.join(VOLUME_SUFFIXES)})")
    if data.dtype == bool:
        data = data.astype(np.uint8)
    atomic_write(str(path), lambda tmp: _WRITERS[fmt](tmp, like, data), protect)


def _write_nifti(tmp, like, data):
    nibabel = need("nibabel", "NIfTI volumes")

    header = like.header.copy() if like.format == "nifti" else None
    image = nibabel.Nifti1Image(data, like.affine, header=header)
    image.header.set_data_dtype(data.dtype)
    image.header.set_slope_inter(1.0, 0.0)  # the values as they are
    image.header["cal_min"], image.header["cal_max"] = float(data.min()), float(data.max())
    # nibabel picks the file type from the name; the temporary file ends like the output.
    nibabel.save(image, tmp)


def _write_nrrd(tmp, like, data):
    nrrd = need("nrrd", "NRRD volumes")

    header = dict(like.header) if like.format == "nrrd" else {
        "space": "right-anterior-superior", "space directions": like.affine[:3, :3].T,
        "space origin": like.affine[:3, 3]}
    for key in ("type", "dimension", "sizes", "datafile", "data file", "byteskip", "byte skip", "lineskip",
                "line skip"):  # taken from the data, written in the output file itself
        header.pop(key, None)
    for key in _NRRD_PER_AXIS:  # a 4-D file with one volume was read as 3-D
        if key in header and len(header[key]) > data.ndim:
            header[key] = header[key][:data.ndim]
    nrrd.write(tmp, data, header)


_NRRD_PER_AXIS = ("kinds", "labels", "units", "space directions", "centerings", "thicknesses", "spacings",
                  "axis mins", "axis maxs")


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


def _write_npy(tmp, like, data):
    with open(tmp, "wb") as f:
        np.save(f, data, allow_pickle=False)


_WRITERS = {"nifti": _write_nifti, "nrrd": _write_nrrd, "tiff": _write_tiff, "npy": _write_npy}
