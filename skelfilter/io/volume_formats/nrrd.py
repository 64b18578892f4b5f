"""NRRD volumes (``.nrrd``, detached data beside the header only) through pynrrd; world
coordinates are right-anterior-superior as NIfTI's, whatever the file's space."""

import os

import numpy as np

from skelfilter.errors import InputError
from skelfilter.io.volume import Volume, check_claimed_size
from skelfilter.io.volume_formats import VolumeFormat
from skelfilter.runtime.extras import need

# NRRD spaces whose first two axes point the other way from NIfTI's right-anterior-superior.
_LPS_SPACES = ("left-posterior-superior", "lps")
_RAS_SPACES = ("right-anterior-superior", "ras")


def _read_nrrd(path):
    nrrd = need("nrrd", "NRRD volumes")

    header = nrrd.read_header(path)
    _check_data_file(path, header)
    if "sizes" in header:
        check_claimed_size(path, header["sizes"], _nrrd_itemsize(nrrd, header))
    data, header = nrrd.read(path)
    space = str(header.get("space", "")).lower()
    if space and space not in _LPS_SPACES + _RAS_SPACES:
        raise InputError(f"{path}: NRRD space {header['space']!r} is not supported (use "
                         "right-anterior-superior or left-posterior-superior)")
    affine = np.eye(4)
    directions = header.get("space directions")
    if directions is not None:
        affine[:3, :3] = _space_directions(path, directions).T
    elif "spacings" in header:
        affine[:3, :3] = np.diag(np.asarray(header["spacings"], dtype=float)[:3])
    if "space origin" in header:
        affine[:3, 3] = np.asarray(header["space origin"], dtype=float)
    if space in _LPS_SPACES:  # world coordinates are RAS, as NIfTI's, whatever the file's convention
        affine = np.diag([-1.0, -1.0, 1.0, 1.0]) @ affine
    return Volume(data, affine, "nrrd", header)


def _space_directions(path, directions):
    """The three spatial axes' vectors, one per row; an axis that is not spatial (``none``, read as
    None or NaN: the fourth of a 4-D file) is left out."""
    rows = [np.asarray(d, dtype=float) for d in np.asarray(directions, dtype=object) if d is not None]
    rows = [d for d in rows if not np.isnan(d).all()]
    if len(rows) != 3 or any(d.shape != (3,) or not np.isfinite(d).all() for d in rows):
        shown = "; ".join(" ".join(f"{v:g}" for v in np.ravel(d)) for d in rows)[:120]
        raise InputError(f"{path}: its space directions ({shown}) are not three vectors of three finite numbers "
                         "(a 3-D volume in a 3-D space)")
    return np.stack(rows)


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


FORMAT = VolumeFormat("nrrd", (".nrrd",), _read_nrrd, _write_nrrd)
