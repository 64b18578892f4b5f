"""Volume files in and out, whatever their format (:mod:`skelfilter.io.volume_formats`: NIfTI,
NRRD, TIFF stacks, VTK image data, NumPy ``.npy``).

A volume is read as an array indexed ``(i, j, k)`` and the affine that takes an index to the
scanner's world coordinates (millimetres for NIfTI and NRRD): ``world = affine @ (i, j, k, 1)``.

What the denoiser works on is a binary mask chosen from the data (`select_mask`): the set voxels of
a mask, one label of a label map, or a grey-level image above an iso level. The output keeps the
input's format, grid, header and affine (`save_volume`), and a label map keeps every other label
(`merge_label`).
"""

import warnings

import numpy as np

from skelfilter.errors import InputError, ResourceError, SkelfilterError
from skelfilter.io.formats import volume_format, volume_suffixes
from skelfilter.io.input_files import check_input_file
from skelfilter.io.output_files import atomic_write
from skelfilter.io.volume import Volume
from skelfilter.params.volume_input import SPACING_LIMITS
from skelfilter.runtime import native_output
from skelfilter.runtime.extras import MissingExtra

__all__ = ["Volume", "label_values", "load_volume", "merge_label", "save_volume", "select_mask"]


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
        raise InputError(f"{path}: not a volume file (use {', '.join(volume_suffixes())})")
    check_input_file(path, "volume")
    try:
        volume, said = _read_quietly(fmt, path)
    except (InputError, ResourceError, MissingExtra):  # a missing reader is no malformed file
        raise
    except MemoryError:
        raise ResourceError(f"{path}: the volume does not fit in the memory available") from None
    except Exception as exc:  # each library raises its own kinds on corrupt files
        raise InputError(f"{path}: malformed {fmt.name.upper()} file ({str(exc) or type(exc).__name__})") from None
    if volume.data.ndim == 4 and volume.data.shape[3] == 1:
        volume.data = volume.data[..., 0]
    if volume.data.ndim != 3:
        raise InputError(f"{path}: a volume must be 3-D, got shape {volume.data.shape}")
    if spacing is not None:  # checked by params.VolumeParams
        volume.affine = volume.affine.copy()
        volume.affine[:3, :3] = volume.affine[:3, :3] / volume.spacing * np.asarray(spacing, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):  # huge entries: refused here, in one line
        whole = np.isfinite(volume.affine).all() and np.isfinite(volume.spacing).all() and \
            abs(np.linalg.det(volume.affine[:3, :3])) > 0
    if not whole:
        raise InputError(f"{path}: the voxel-to-world matrix is singular or not finite")
    low, high = SPACING_LIMITS
    if not (low <= volume.spacing.min() and volume.spacing.max() <= high):
        size = " x ".join(f"{s:g}" for s in volume.spacing)
        raise InputError(f"{path}: its voxels measure {size} world units, outside [{low:g}, {high:g}] (give "
                         "`spacing` to replace the file's)")
    _check_precision(path, volume)
    for line in said:  # the file is read: what its library said is worth a warning
        warnings.warn(f"{path}: {line}", stacklevel=2)
    return volume


# The share of a voxel that double-precision world coordinates must resolve.
_WORLD_RESOLUTION = 1e-6


def _check_precision(path, volume):
    """Refuse a grid lying so far from the world origin, for its spacing, that double-precision world
    coordinates cannot keep its voxels apart (the surface would come back collapsed)."""
    corners = np.stack(np.meshgrid(*[[0, n - 1] for n in volume.data.shape], indexing="ij"), -1).reshape(-1, 3)
    reach = float(np.abs(corners @ volume.affine[:3, :3].T + volume.affine[:3, 3]).max())
    spacing = float(volume.spacing.min())
    if reach * np.finfo(np.float64).eps > _WORLD_RESOLUTION * spacing:
        raise InputError(f"{path}: its voxels lie {reach:.3g} from the world origin and {spacing:.3g} apart: "
                         "double precision cannot keep them apart (move the volume's origin nearer to it)")


def _read_quietly(fmt, path):
    """``fmt.read(path)`` and what its library printed, logged or warned meanwhile (distinct lines),
    held back: `load_volume` says them as warnings once the file is accepted, and drops them where it
    is refused (the error says it once)."""
    with native_output.captured() as said, warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            volume = fmt.read(path)
        finally:
            told = said()
    lines = [str(w.message) for w in caught] + [line.removeprefix("skelfilter: warning: ") for line in told]
    return volume, list(dict.fromkeys(line for line in lines if line))


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
    if np.issubdtype(data.dtype, np.complexfloating):
        raise InputError(f"volume data of type {data.dtype} is complex: a shape needs real values")
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


def label_values(data):
    """The labels of a label map, 0 (the background) left out.

    Raises
    ------
    InputError
        Data that is not whole numbers, or no label.
    """
    if not (np.issubdtype(data.dtype, np.integer) or data.dtype == bool):
        values = data[np.isfinite(data)] if np.issubdtype(data.dtype, np.floating) else data
        if values.size < data.size or not np.array_equal(values, np.round(values)):
            raise InputError(f"volume data of type {data.dtype} with fractions or NaN is not a label map: "
                             "`all_labels` needs whole numbers")
    labels = [v.item() for v in np.unique(data) if v != 0]
    if not labels:
        raise InputError("the volume is empty: no voxel is labelled")
    return labels


def set_value(data, mask):
    """The value the set voxels of a mask stored in ``data`` hold (1, or 255 for an 8-bit image mask)."""
    return data[mask].flat[0]


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
        raise InputError(f"{path}: not a volume file (use {', '.join(volume_suffixes())})")
    data = _storable(data)

    def write(tmp):
        try:
            fmt.write(tmp, like, data)
        except (OSError, MemoryError, SkelfilterError):
            raise
        except Exception as exc:  # each library refuses the types it has no code for in its own way
            raise InputError(f"{path}: a {fmt.name.upper()} file cannot hold this volume's values (type "
                             f"{data.dtype}: {str(exc) or type(exc).__name__}); choose another output format") \
                from None

    atomic_write(str(path), write, protect)


def _storable(data):
    """``data`` in a type every volume format stores: a mask as bytes, half floats as single ones
    (NIfTI, NRRD and VTK have no half floats)."""
    if data.dtype == bool:
        return data.astype(np.uint8)
    if data.dtype == np.float16:
        return data.astype(np.float32)
    return data


