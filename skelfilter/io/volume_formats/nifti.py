"""NIfTI-1 volumes (``.nii``, ``.nii.gz``) through nibabel: the affine and header as stored."""

import os

import numpy as np

from skelfilter.io.volume import Volume, check_claimed_size
from skelfilter.io.volume_formats import VolumeFormat
from skelfilter.runtime.extras import need


def _read_nifti(path):
    nibabel = need("nibabel", "NIfTI volumes")

    image = nibabel.load(path)
    compressed = path.lower().endswith(".gz")
    offset = int(image.dataobj.offset) if hasattr(image.dataobj, "offset") else 0
    check_claimed_size(path, image.shape, image.get_data_dtype().itemsize,
                        None if compressed else os.path.getsize(path) - offset)
    return Volume(np.asanyarray(image.dataobj), np.asarray(image.affine, dtype=float), "nifti", image.header)



def _write_nifti(tmp, like, data):
    nibabel = need("nibabel", "NIfTI volumes")

    header = like.header.copy() if like.format == "nifti" else None
    image = nibabel.Nifti1Image(data, like.affine, header=header, dtype=data.dtype)  # 64-bit types too
    image.header.set_data_dtype(data.dtype)
    image.header.set_slope_inter(1.0, 0.0)  # the values as they are
    image.header["cal_min"], image.header["cal_max"] = float(data.min()), float(data.max())
    # nibabel picks the file type from the name; the temporary file ends like the output.
    nibabel.save(image, tmp)


FORMAT = VolumeFormat("nifti", (".nii.gz", ".nii"), _read_nifti, _write_nifti)
