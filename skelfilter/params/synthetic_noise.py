"""The parameters of the thesis' synthetic noise (`NoiseParams`, §7.2)."""

import math
from dataclasses import dataclass

from skelfilter.errors import ParameterError
from skelfilter.parameter_fields import ABSOLUTE, check_limits
from skelfilter.parameter_fields import parameter as _p


@dataclass(frozen=True)
class NoiseParams:
    """Parameters of the thesis' noise model (§7.2)."""

    p: float = _p(
        0.014, "Incidence p", "incidence: probability that a surface voxel starts a protrusion", "probability",
        limits=(0, 1),
    )
    r: float = _p(2.1, "Kernel radius r", "radius of the spherical noise kernel (eq. 7.13)", "voxels",
                  measure=ABSOLUTE, limits=(0.01, 1000))
    h: int = _p(3, "Height h", "height of the protrusion along the normal (eq. 7.14)", "voxels",
                measure=ABSOLUTE, limits=(0, 1000))
    l: int = _p(
        6, "Walk length l", "length of the random surface walk; 1 gives isolated bumps (eq. 7.15-7.16)",
        "steps", limits=(1, 100_000),
    )
    seed: int = _p(0, "Random seed", "random seed; equal seeds give equal noise", limits=(0, 2**32 - 1))
    dents: bool = _p(False, "Dents", "also carve dents inward, at independently drawn sites")
    resolution: int = _p(160, "Resolution", "voxels along the longest side of the bounding box", "voxels",
                         limits=(16, 4096))

    def __post_init__(self):
        check_limits(self)
        if not isinstance(self.dents, bool):
            raise ParameterError(f"dents must be true or false, got {self.dents!r}")

    @property
    def padding_voxels(self):
        """Room left around the shape so protrusions never reach the border."""
        return int(math.ceil(self.h + self.r)) + 10
