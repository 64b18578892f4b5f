"""How a volume file becomes the shape to denoise (`VolumeParams`)."""

import math
import numbers
from dataclasses import dataclass

import numpy as np

from skelfilter.errors import ParameterError
from skelfilter.parameter_fields import check_limits
from skelfilter.parameter_fields import parameter as _p

SPACING_LIMITS = (1e-6, 1e6)
"""The voxel sizes skelfilter works with, in world units (a nanometre to a kilometre in millimetres)."""


@dataclass(frozen=True)
class VolumeParams:
    """How a volume file becomes the shape to denoise (``skelfilter denoise`` and ``batch`` on NIfTI,
    NRRD, TIFF and .npy files)."""

    label: int | None = _p(None, "Label", "denoise the voxels of this label of a label map; the other labels "
                           "stay as they are", limits=(-2**63, 2**63 - 1))
    all_labels: bool = _p(False, "All labels", "every label at once, a part each (.obj, .glb)")
    iso: float | None = _p(None, "Iso level", "denoise the voxels at or above this grey level of an image",
                           "grey level", limits=(-1e308, 1e308))
    spacing: tuple | None = _p(None, "Spacing", "voxel size along the three axes, replacing the file's (a .npy "
                               "file has none: unit voxels)", "world units")

    def __post_init__(self):
        check_limits(self)
        if sum((self.label is not None, self.iso is not None, bool(self.all_labels))) > 1:
            raise ParameterError("give one of label, all_labels and iso")
        if self.spacing is not None:
            spacing = tuple(self.spacing)
            low, high = SPACING_LIMITS
            if len(spacing) != 3 or not all(isinstance(s, numbers.Real) and not isinstance(s, (bool, np.bool_))
                                            and math.isfinite(s) and low <= s <= high for s in spacing):
                got = " ".join(f"{s:g}" if isinstance(s, numbers.Real) else repr(s) for s in spacing)
                raise ParameterError(f"spacing must be three numbers in [{low:g}, {high:g}], got {got}")
            object.__setattr__(self, "spacing", tuple(float(s) for s in spacing))
