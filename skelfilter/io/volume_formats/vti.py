"""VTK image data (``.vti``, what ParaView and 3D Slicer's VTK export write) through VTK's XML
reader and writer: the point data's first scalar array (or its only array) on the image's grid, whose
origin, spacing and direction make the affine; the array's name is written back."""

import mmap
import re
from xml.sax.saxutils import escape

import numpy as np

from skelfilter.errors import InputError
from skelfilter.io.volume import Volume, check_claimed_size
from skelfilter.io.volume_formats import VolumeFormat
from skelfilter.runtime import native_output
from skelfilter.runtime.extras import need

_PURPOSE = "VTK image data (.vti)"


def _read_vti(path):
    xml = need("vtkmodules.vtkIOXML", _PURPOSE, extra="volumes")
    support = need("vtkmodules.util.numpy_support", _PURPOSE, extra="volumes")
    reader = xml.vtkXMLImageDataReader()
    if not reader.CanReadFile(path):
        raise InputError(f"{path}: malformed VTI file (not VTK XML image data)")
    _check_whole(path)
    reader.SetFileName(path)
    with native_output.captured() as said:
        reader.UpdateInformation()
        extent = reader.GetOutputInformation(0).Get(reader.GetExecutive().WHOLE_EXTENT())
        dims = tuple(int(extent[2 * i + 1]) - int(extent[2 * i]) + 1 for i in range(3)) if extent else (0, 0, 0)
        check_claimed_size(path, dims, 1)  # an impossible size is refused before the data is read
        reader.Update()
        complaint = " | ".join(line for line in said() if "ERROR" in line)
    image = reader.GetOutput()
    arrays = image.GetPointData()
    scalars = arrays.GetScalars() or (arrays.GetArray(0) if arrays.GetNumberOfArrays() else None)
    if reader.GetErrorCode() or scalars is None or min(image.GetDimensions()) < 1:
        raise InputError(f"{path}: malformed VTI file ({complaint[:300] or 'no point data could be read'})")
    if scalars.GetNumberOfComponents() != 1:
        raise InputError(f"{path}: its point data {scalars.GetName()!r} has {scalars.GetNumberOfComponents()} "
                         "components; a volume has one value per voxel")
    dims = image.GetDimensions()
    data = support.vtk_to_numpy(scalars).reshape(dims[::-1]).transpose(2, 1, 0)  # x varies fastest
    direction = np.asarray([image.GetDirectionMatrix().GetElement(r, c) for r in range(3) for c in range(3)],
                           dtype=float).reshape(3, 3)
    affine = np.eye(4)
    with np.errstate(over="ignore", invalid="ignore"):  # a huge spacing: refused as not finite by load_volume
        affine[:3, :3] = direction * np.asarray(image.GetSpacing(), dtype=float)
        affine[:3, 3] = np.asarray(image.GetOrigin(), dtype=float) + affine[:3, :3] @ np.asarray(image.GetExtent()[::2])
    return Volume(np.ascontiguousarray(data), affine, "vti", {"name": scalars.GetName() or "values"})


# What VTK's reader reads silently as a default (a bad number) or as zeros (data that is not there).
_NUMBERS = {b"WholeExtent": (6, int), b"Origin": (3, float), b"Spacing": (3, float), b"Direction": (9, float)}


def _check_whole(path):
    """Refuse what VTK's reader would read without a word: a file cut short (its data would be
    uninitialised), an ``ImageData`` attribute that is not its count of finite numbers (it would be
    the default), and image data in several pieces or in a piece smaller than the whole extent (the
    rest would be zeros)."""
    with open(path, "rb") as f, mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as data:
        if not data[-256:].rstrip().endswith(b"</VTKFile>"):
            raise InputError(f"{path}: the VTI file is truncated (it does not end with </VTKFile>)")
        appended = data.find(b"<AppendedData")
        head = data[:appended if appended >= 0 else len(data)]
    image = re.search(rb"<ImageData\b([^>]*)>", head)
    if image is None:
        raise InputError(f"{path}: malformed VTI file (no <ImageData> element)")
    attributes = dict(re.findall(rb'(\w+)\s*=\s*"([^"]*)"', image.group(1)))
    for name, (count, kind) in _NUMBERS.items():
        if name in attributes or name == b"WholeExtent":
            text = attributes.get(name, b"").decode("latin-1")
            try:
                values = [kind(word) for word in text.split()]
            except ValueError:
                values = []
            if len(values) != count or not np.isfinite(values).all():
                raise InputError(f"{path}: malformed VTI file ({name.decode()}=\"{text[:60]}\" is not {count} "
                                 f"finite {'whole ' if kind is int else ''}numbers)")
    pieces = re.findall(rb'<Piece\b[^>]*?Extent\s*=\s*"([^"]*)"', head)
    whole = attributes[b"WholeExtent"].split()
    if len(pieces) != 1 or pieces[0].split() != whole:
        got = f"{len(pieces)} pieces" if len(pieces) != 1 else f"a piece of extent {pieces[0].decode('latin-1')[:60]}"
        raise InputError(f"{path}: the VTI file holds {got}, not one piece of its whole extent "
                         f"{attributes[b'WholeExtent'].decode('latin-1')}; save the image in one piece")


def _write_vti(tmp, like, data):
    xml = need("vtkmodules.vtkIOXML", _PURPOSE, extra="volumes")
    support = need("vtkmodules.util.numpy_support", _PURPOSE, extra="volumes")
    data_model = need("vtkmodules.vtkCommonDataModel", _PURPOSE, extra="volumes")
    spacing = like.spacing
    image = data_model.vtkImageData()
    image.SetDimensions(*data.shape)
    image.SetSpacing(*spacing)
    image.SetOrigin(*like.affine[:3, 3])
    direction = like.affine[:3, :3] / spacing
    image.SetDirectionMatrix(*direction.ravel())
    values = support.numpy_to_vtk(np.ascontiguousarray(data.transpose(2, 1, 0)).ravel(), deep=True)
    name = (like.header or {}).get("name", "values") if like.format == "vti" else "values"
    values.SetName(escape(name, {'"': "&quot;"}))  # VTK writes the name into an attribute as it is
    image.GetPointData().SetScalars(values)
    writer = xml.vtkXMLImageDataWriter()
    writer.SetFileName(tmp)
    writer.SetInputData(image)
    with native_output.captured() as said:
        written, complaint = writer.Write(), " | ".join(said())[:200]
    if written != 1:
        raise OSError(f"VTK could not write the image data ({complaint})")


FORMAT = VolumeFormat("vti", (".vti",), _read_vti, _write_vti)
