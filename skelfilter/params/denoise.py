"""The skeleton saliency denoiser's parameters (`DenoiseParams`) and which of them a mesh reads."""

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from skelfilter.errors import ParameterError
from skelfilter.parameter_fields import ABSOLUTE, RELATIVE, check_applies, check_limits
from skelfilter.parameter_fields import parameter as _p
from skelfilter.presets import PRESET_CHOICES, PRESETS


@dataclass(frozen=True)
class DenoiseParams:
    """Parameters of the skeleton saliency denoiser (thesis §8.1.1-8.1.2)."""

    preset: str = _p(
        "default",
        "Preset",
        "the method's main choices for every field left unset: 'default' (measured best on the "
        "quality benchmark: the foreground stage, and both sides decided where the input has dents, "
        "t = 0.1875 of the longest side, i.e. 30 voxels at resolution 160), 'thesis' (the thesis' "
        "pipeline as printed, §8.1.1-8.1.2: both stages, t = 18 voxels, rho+ by eq. 5.6 over every "
        "neighbour) or 'thesis-tuned' (the same with rho+ taken from the neighbours ahead along v and no "
        "derivative below rho = 7 voxels, as the default)",
        choices=tuple(PRESETS),
        summary=("the method's main choices: 'default', or the thesis' pipeline as printed ('thesis') or "
                 "tuned ('thesis-tuned')"),
    )
    resolution: int | None = _p(
        None,
        "Resolution",
        "voxels along the longest side of the mesh's bounding box; unset: a voxel mesh (marching cubes "
        "of a volume) on the grid it was made on, up to 256; any other twice the longest side over the "
        "mesh's mean edge length, within 96-256; lowered to fit in memory",
        "voxels",
        limits=(16, 4096),
        summary=("voxels along the longest side of the grid the skeleton is computed on (default: chosen "
                 "from the mesh, 96-256)"),
    )
    output_mesh: str = _p(
        "preset",
        "Output mesh",
        "'input': the input mesh itself with its vertices moved (same faces in the same order, "
        "colours and UVs kept, an open surface stays open): where the input is a solid, vertices of "
        "removed bumps and filled dents go onto the denoised surface; then the fine pass; "
        "'closed': a new watertight marching-cubes mesh of the denoised solid (the CLI's --close; an open "
        "surface is refused); "
        "'auto': the input as it was where its surface roughness finds no noise, 'closed' for a solid "
        "covered in noise at the skeleton's scale, else 'input' with the fine pass only; "
        "'preset': the preset's (default: auto; thesis: closed)",
        choices=("preset", "auto", "input", "closed"),
        summary=("'auto' (default): the input mesh with its vertices moved, or a new closed mesh for a "
                 "solid covered in noise; 'input'; 'closed'"),
    )
    fine_pass: str = _p(
        "preset",
        "Fine pass",
        "smooth the noise below the skeleton's scale, keeping edges and thin parts, as strong as the "
        "noise measured on the input: with the input mesh as output, bilateral filtering of the face "
        "normals (Zheng et al. 2011), then vertices fitted to them (Sun et al. 2007); on a volume, "
        "before the voxel stage, Gaussians of the mask from sigma 2 voxels down, each where it removes "
        "or adds no part standing out of the noise, islands and pits removed; 'auto': where the input "
        "measures noisy (a mesh: its surface roughness) or the voxel stage moved vertices; 'on': always; "
        "'off': never; 'preset': the preset's (default: auto; thesis: off)",
        choices=("preset", "auto", "on", "off"),
        summary=("smooth the noise smaller than a voxel, keeping edges: 'auto' (default: where the input "
                 "has such noise), 'on', 'off'"),
    )
    normal_filter: str = _p(
        "adaptive",
        "Fine pass normal filter",
        "how the fine pass filters a mesh's face normals: 'adaptive' (bilateral filtering, Zheng et al. "
        "2011, blended towards guided filtering, Zhang et al. 2015, where the surface is piecewise flat, "
        "which keeps creases sharp) or 'bilateral' (bilateral filtering alone, the first fine pass)",
        choices=("adaptive", "bilateral"),
    )
    padding: int | None = _p(
        None,
        "Padding",
        "empty voxels added around the shape on every side; the background stage works inside "
        "this padded box (default: max(8, t/2 + 2))",
        "voxels",
        measure=ABSOLUTE,
        limits=(2, 4096),
    )
    threshold: float | None = _p(
        None,
        "Importance threshold t",
        "importance threshold t on rho+ (eq. 5.6): skeleton parts whose streamline importance is "
        "below t are pruned; t must exceed the geodesic width of the noise to remove "
        "(about 2h + pi r for a ridge of height h and radius r); unset: the preset's "
        "(default: 0.1875 of the longest side; thesis: 18 voxels); the preset's t given in voxels (30 at "
        "resolution 160) is the preset's and changes nothing; whether the stages prune at t whatever the "
        "noise is `prune`'s",
        "voxels",
        measure=ABSOLUTE,
        limits=(1e-6, 10000),
    )
    threshold_relative: float | None = _p(
        None,
        "Relative importance threshold",
        "threshold t as a fraction of the longest bounding-box side (overrides the threshold in "
        "voxels; t = threshold_relative * resolution voxels); unset with the threshold unset: the "
        "preset's",
        "fraction",
        measure=RELATIVE,
    )
    thin_radius_relative: float | None = _p(
        None,
        "Thin part radius",
        "the half thickness that tells thin parts from noise, as a fraction of the longest side: "
        "skeleton voxels in the middle of a thin part (feature points on opposite sides, object "
        "angle >= 150 deg) with a ball at least this large are kept whatever their importance, so "
        "plates, walls and rims survive a large t; kept skeleton pieces cut off by the pruning whose "
        "balls are all smaller are pruned, and voxel-thin spikes are peeled off; 1 turns these "
        "rules off; unset: the preset's (default: 0.025, i.e. 4 voxels at resolution 160; thesis: 1)",
        "fraction",
        measure=RELATIVE,
    )
    keep_features: str = _p(
        "preset",
        "Keep features",
        "'on': measure the noise on what the pruning removes (how high its peaks stand above the "
        "kept shape, and over how much of the surface) and give back what is no noise: every "
        "removed part that stands higher than the noise (a leg, a wing, a fin, a rim), but for the "
        "noise on it, which no straight run of the shape longer than the noise passes through, and "
        "whatever joined pieces the pruning cut apart; where no noise is found the input passes "
        "through unchanged (with `prune` measured); 'off': the pruning as it is; 'preset': the preset's (default: on; "
        "thesis: off)",
        choices=("preset", "on", "off"),
    )
    prune: str = _p(
        "preset",
        "Prune",
        "'measured': each stage measures the noise on what its pruning at t removes first, and prunes only "
        "where it finds noise at the skeleton's scale (where it finds none the input passes through "
        "unchanged; a volume's fine pass runs before it); 'as-told': prune at t whatever the noise; "
        "'preset': the preset's (default: measured; thesis: as-told)",
        choices=("preset", "measured", "as-told"),
    )
    noise_height: float | None = _p(
        None,
        "Noise height",
        "the height of the noise to remove, replacing the estimate: removed parts standing higher "
        "above the kept shape come back (with keep features on); unset: measured on the input",
        "voxels",
        measure=ABSOLUTE,
        limits=(0.01, 10000),
        summary=("the height of the noise to remove, in voxels: removed bumps and dents up to it stay "
                 "removed, taller parts come back as features (default: measured on the input)"),
    )
    k: float = _p(
        0.9, "Derivative threshold k",
        "derivative threshold k: skeleton voxels with sigma_bar <= k are ligature (eq. 5.6)",
        limits=(0, 100),
    )
    derivative_guard: float = _p(
        0.1,
        "Derivative guard l",
        "guard l of eq. 4.3: where grad D . v < l the derivative measure is undefined and the voxel "
        "is never treated as ligature",
        "voxels",
        measure=ABSOLUTE,
        limits=(0, 100),
    )
    derivative_min_rho: float | None = _p(
        None,
        "Least importance for the derivative",
        "below this importance rho the derivative measure is left undefined (like the guard l of "
        "eq. 4.3): on structures a few voxels across, such as the voxel steps of slanted surfaces, "
        "the grid's quantization of rho and D swamps sigma_bar; such voxels are never ligature and "
        "take rho+ from any neighbour; 1 leaves out only voxels whose two feature points are one "
        "(rho = 0); unset: the preset's (default and thesis-tuned: 7; thesis: 1)",
        "voxels",
        measure=ABSOLUTE,
        limits=(1, 10000),
    )
    pruning: str = _p(
        "global",
        "Pruning rule",
        "how skeleton voxels are selected: 'global' (threshold t on the global streamline importance "
        "rho+, eq. 5.6, §5.2.2), 'direct' (threshold t on rho+ of the direct streamlines, eq. 5.1-5.3, "
        "§5.2.1), 'derivative' (the connected component of the root among the voxels with rho >= t "
        "that are not ligature, sigma_bar > k, eq. 4.4) or 'saliency' (the root's component among the "
        "voxels with saliency rho / D >= c, eq. 3.1-3.2, Telea's original rule)",
        choices=("global", "direct", "derivative", "saliency"),
    )
    rho_plus_from: str = _p(
        "preset",
        "rho+ from",
        "which visited 26-neighbours a voxel takes rho+ from in eq. 5.6: 'ahead' (those within the cone "
        "along v that the derivative measure steps in, so that core importance does not leak sideways "
        "along noise sheets of equal rho) or 'any' (every one, eq. 5.6 as printed); 'preset': the "
        "preset's (default and thesis-tuned: ahead; thesis: any)",
        choices=("preset", "ahead", "any"),
    )
    saliency_threshold: float = _p(
        1.0,
        "Saliency threshold c",
        "with the 'saliency' pruning rule, skeleton voxels with rho / D >= c are selected (eq. 3.2); "
        "a core sheet has rho / D >= 2 (its feature points lie on opposite sides, at least 2 D apart "
        "along the boundary), a ligature sheet's falls towards 0 as D grows along it",
        limits=(1e-6, 1000),
        applies={"pruning": ("saliency",)},
    )
    stages: str = _p(
        "preset",
        "Stages",
        "which stages run: foreground removes bumps, background removes dents (§3.1.1); 'auto': the "
        "foreground, then, where its result is pitted (the input has dents too), both sides decided ball "
        "by ball against the input's modal reading on its thick parts; 'preset': the preset's "
        "(default: auto; thesis: both)",
        choices=("preset", "both", "foreground", "background", "auto"),
        summary="remove bumps, and dents where found ('auto', default)",
    )
    unchanged_surface: str = _p(
        "preset",
        "Unchanged surface",
        "the output surface where the denoising changed no voxel (2 voxels away from any change): "
        "the input mesh's own surface (sub-voxel, its edges as they were) or the reconstruction's "
        "(marching cubes of the union of balls); 'preset': the preset's (default: input; thesis: "
        "reconstruction)",
        choices=("preset", "input", "reconstruction"),
    )
    surface: str = _p(
        "preset",
        "Surface",
        "the output surface wherever it is made from voxels (a new closed mesh, a volume's or a point "
        "cloud's mesh): 'smooth': the voxels' field smoothed under their constraint (every set voxel's "
        "centre stays inside, every other outside): the smooth surface the voxels sample, without the "
        "staircase of thick slices or of the grid, enclosing exactly the output's voxels; 'plain': its "
        "marching cubes as it is (the thesis' union of balls, a mask's staircase); 'preset': the "
        "preset's (default: smooth; thesis: plain)",
        choices=("preset", "smooth", "plain"),
    )
    noise_handles: str = _p(
        "keep",
        "Noise handles",
        "tunnels the noise leaves through the denoised voxels (bumps side by side, a bump arched over a "
        "dent, a thin wall pierced): 'close' fills the holes a closing by the 6-neighbour cross fills "
        "wherever the fill closes a tunnel (it raises the Euler characteristic, joins no pieces and seals "
        "no cavity), so a pit or a crease stays open and a tunnel wider than a voxel or two (a handle, a "
        "ring, the gap under an arm) is kept; it lowers the voxels' genus, at a little more distance to "
        "the clean shape where a fill stands under a bump; 'keep': the voxels as the stages left them",
        choices=("keep", "close"),
    )
    edt_filter: str = _p(
        "minify",
        "EDT filter",
        "filter of the kept skeleton voxels' radii against EDT ripples (§6.2): kernels over the ball of "
        "radius r (eq. 6.1), on every voxel of the shape (implicit) or, with 'explicit-', on the kept "
        "skeleton voxels only: 'minify' (minimum + r where D >= r), 'mean', 'median', 'opening' "
        "(minimum, then maximum); 'least-squares' (projection on the local plane of (x, D), eq. "
        "6.2-6.4); 'flat' (radii shrunk off the segments between the pruned voxels' feature points, "
        "§6.2.3); 'none'. The reconstruction is kept inside the shape (the anti-extensiveness eq. 6.1 "
        "asks for), where a filter raised a radius above D",
        choices=("minify", "explicit-minify", "mean", "explicit-mean", "median", "explicit-median",
                 "opening", "explicit-opening", "least-squares", "flat", "none"),
    )
    minify_radius: float = _p(
        3.0, "EDT filter radius r", "radius r of the EDT filter's neighbourhood (§6.2, the thesis uses 3)",
        "voxels",
        measure=ABSOLUTE,
        limits=(0, 100),
    )
    importance: str = _p(
        "geodesic",
        "Importance measure",
        "importance rho: graph geodesic over the boundary layer (§3.1.2), its estimate (eq. 7.22) "
        "or the Euclidean distance of the feature points",
        choices=("geodesic", "estimate", "euclidean"),
    )
    geodesic_cap: float | None = _p(
        None,
        "Geodesic search cap",
        "geodesics are searched up to this length and longer ones are set to it; any cap above t "
        "leaves the kept/pruned decision of every voxel unchanged in practice with the streamline "
        "rules (unset: t + 8 with the default preset, max(2t, t+8) with the thesis'; 4t with the "
        "'derivative' and 'saliency' pruning rules, whose measures read rho itself and count as met "
        "where rho reaches the cap)",
        "voxels",
        measure=ABSOLUTE,
        limits=(1e-6, 20000),
    )
    skeleton: str = _p(
        "ie",
        "Skeleton rule",
        "surface skeleton rule: IE (eq. 7.7, E >= 1), IMA (eq. 7.1-7.2) or USM (§7.1.2: the voxels where "
        "the boundary's mass, advected along the contraction of the shape smoothed by the USM smoothing, "
        "reaches a density above the USM least density, eq. 7.8-7.11; neither thin nor always centred)",
        choices=("ie", "ima", "usm"),
    )
    velocity: str = _p(
        "feature",
        "Velocity field",
        "velocity field v of the derivative measure: feature-point based (eq. 4.16), grad D (eq. 4.7), "
        "grad rho (eq. 4.5, differences along the skeleton) or unified (the USM contraction direction, "
        "eq. 4.10: grad D of the shape smoothed by the USM smoothing)",
        choices=("feature", "edt-gradient", "importance-gradient", "unified"),
    )
    usm_smoothing: float = _p(
        1.0,
        "USM smoothing",
        "standard deviation of the Gaussian the shape is smoothed with before the USM contraction "
        "(§7.1.3); 0: none",
        "voxels",
        measure=ABSOLUTE,
        limits=(0, 100),
        applies={"skeleton": ("usm",), "velocity": ("unified",)},
    )
    usm_min_density: float = _p(
        1.0,
        "USM least density",
        "with the USM skeleton, voxels whose largest advected density lambda (eq. 7.11) exceeds this are "
        "skeleton; 1 is the mass of one boundary voxel, which a front carries past voxels off the skeleton",
        "boundary voxels",
        limits=(0, 1e9),
        applies={"skeleton": ("usm",)},
    )

    def __post_init__(self):
        if self.preset not in PRESETS:
            raise ParameterError(f"preset must be one of {', '.join(PRESETS)}, got {self.preset!r}")
        if isinstance(self.fine_pass, (bool, np.bool_)):  # the Python API's earlier true/false
            object.__setattr__(self, "fine_pass", "on" if self.fine_pass else "off")
        self._apply_preset()
        check_limits(self)
        check_applies(self)
        for f in fields(self):
            choices = f.metadata.get("choices")
            if choices and getattr(self, f.name) not in choices:
                raise ParameterError(
                    f"{f.name} must be one of {', '.join(choices)}, got {getattr(self, f.name)!r}"
                )
        if not (math.isfinite(self.thin_radius_relative) and 0 < self.thin_radius_relative <= 1):
            raise ParameterError(f"thin_radius_relative must be in (0, 1], got {self.thin_radius_relative}")
        if self.threshold_relative is not None and not (
                math.isfinite(self.threshold_relative) and 0 < self.threshold_relative < 1):
            raise ParameterError(f"threshold_relative must be in (0, 1), got {self.threshold_relative}")
        if (self.geodesic_cap is not None and self.resolution is not None
                and self.geodesic_cap <= self.threshold_voxels):
            raise ParameterError("geodesic_cap must be larger than the threshold t")

    def _apply_preset(self):
        """Fill the fields left unset with the preset's values (the dataclass is frozen)."""
        preset = PRESETS[self.preset]
        for name in PRESET_CHOICES:
            if getattr(self, name) == "preset":
                object.__setattr__(self, name, preset[name])
        if self.derivative_min_rho is None:
            object.__setattr__(self, "derivative_min_rho", preset["derivative_min_rho"])
        if self.thin_radius_relative is None:
            object.__setattr__(self, "thin_radius_relative", preset["thin_radius_relative"])
        if self.threshold is None and self.threshold_relative is None:
            object.__setattr__(self, "threshold_relative", preset["threshold_relative"])
            object.__setattr__(self, "threshold", preset["threshold"])

    @property
    def threshold_voxels(self):
        """The threshold t in voxels."""
        if self.threshold_relative is not None:
            if self.resolution is None:
                raise ParameterError("a relative threshold needs the resolution (set it, or let the mesh choose it)")
            return self.threshold_relative * self.resolution
        return float(self.threshold)

    @property
    def threshold_given(self):
        """Whether the caller chose a t other than the preset's (a voxel-stage choice: see
        `voxel_fields_given`). A t equal to the preset's is the preset's, however it was given: as the same
        fraction, or (with the resolution set) as the same number of voxels (``resolution=160,
        threshold=30`` is the default's t)."""
        preset = PRESETS[self.preset]
        if self.resolution is not None:
            relative = preset["threshold_relative"]
            return self.threshold_voxels != (relative * self.resolution if relative is not None
                                             else float(preset["threshold"]))
        return self.threshold_relative != preset["threshold_relative"] or (
            self.threshold is not None and self.threshold != preset["threshold"])

    @property
    def prunes_as_told(self):
        """Whether the stages prune at t whatever the noise (``prune`` as-told); else a stage that finds
        no noise passes its input through."""
        return self.prune == "as-told"

    @property
    def thin_radius_voxels(self):
        """Least half thickness of a kept thin part in voxels; None when no such rule applies."""
        if self.thin_radius_relative >= 1:
            return None
        return self.thin_radius_relative * self.resolution

    @property
    def padding_voxels(self):
        if self.padding is not None:
            return int(self.padding)
        return max(8, int(math.ceil(self.threshold_voxels / 2)) + 2)

    def with_(self, **changes):
        """A copy with ``changes``; a threshold given in voxels replaces a relative one."""
        if changes.get("threshold") is not None and "threshold_relative" not in changes:
            changes["threshold_relative"] = None
        return replace(self, **changes)


# The fields a mesh reads outside the voxel stage (all the others are the voxel stage's).
MESH_FIELDS = ("preset", "output_mesh", "fine_pass", "normal_filter")


def voxel_fields_given(params):
    """The voxel-stage fields of a DenoiseParams that differ from what its preset gives them unset:
    the choices a caller made for the voxel stage (see `MESH_FIELDS`)."""
    base = DenoiseParams(preset=params.preset)
    given = [f.name for f in fields(params)
             if f.name not in MESH_FIELDS and getattr(params, f.name) != getattr(base, f.name)]
    if "threshold" in given and "threshold_relative" in given:  # a threshold in voxels clears the relative one
        given.remove("threshold_relative")
    if not params.threshold_given:  # the preset's t, given as it is in voxels
        given = [name for name in given if name not in ("threshold", "threshold_relative")]
    return given
