"""skelfilter's filters, described the way MeshLab describes its filters.

A :class:`FilterDescription` holds what MeshLab shows of a filter: its name ("Skeleton Saliency
Denoise"), its Python name in PyMeshLab's style (``apply_skeleton_saliency_denoise``), a description
and its parameters. Each :class:`FilterParameter` has MeshLab's type (RichInt, RichFloat, RichBool,
RichEnum, as in .mlx files), a default, a description (the short label of MeshLab's dialog), a
tooltip, and for lengths and thresholds whether the value is absolute (voxels of the grid) or relative
to the model's size (a fraction of its bounding box's longest side), as MeshLab tells ``PureValue``
from ``PercentageValue``.

The parameters are read off the dataclasses of :mod:`skelfilter.params`; the CLI flags, the MeshSet
functions (:mod:`skelfilter.meshlab.meshset`), the .mlx reading and writing (:mod:`skelfilter.meshlab.scripts`) and
``docs/filters.md`` (:func:`markdown`) are built from these descriptions.

MeshLab has no "unset" value: a parameter that is ``None`` in Python (automatic, or off) is 0 in
MeshLab. 0 is never a valid value of such a parameter, so nothing is ambiguous.
"""

import numbers
import typing
from dataclasses import dataclass, fields

import numpy as np

from skelfilter.errors import ParameterError
from skelfilter.parameter_fields import ABSOLUTE, RELATIVE
from skelfilter.params import DenoiseParams, NoiseParams

RICH_TYPES = {bool: "RichBool", int: "RichInt", float: "RichFloat", str: "RichEnum"}

MEASURES = {ABSOLUTE: "absolute", RELATIVE: "relative to the model's size"}


@dataclass(frozen=True)
class FilterParameter:
    """One parameter of a filter, as MeshLab describes it."""

    name: str  # the dataclass field: Python keyword, CLI flag (--name-with-dashes), .mlx Param name
    rich_type: str  # RichInt, RichFloat, RichBool or RichEnum
    value_type: type  # int, float, bool or str
    default: object  # the Python default; None means automatic (0 in MeshLab)
    description: str  # MeshLab's short label
    tooltip: str  # the longer help (also the CLI help)
    unit: str
    measure: str  # ABSOLUTE, RELATIVE or "" (not a length)
    choices: tuple  # the entries of a RichEnum
    optional: bool  # None allowed in Python (written 0 in MeshLab)
    limits: tuple = None  # closed range of a number (parameter_fields.check_limits)
    summary: str = None  # plain words for the CLI's short help; None: shown by --help-all only

    @property
    def full_tooltip(self):
        """The tooltip with the unit and, for lengths and thresholds, the measure."""
        limits = f"range {self.limits[0]:g} to {self.limits[1]:g}" if self.limits else ""
        notes = [n for n in (self.unit, MEASURES.get(self.measure), limits) if n]
        return f"{self.tooltip} [{', '.join(notes)}]" if notes else self.tooltip

    @property
    def meshlab_default(self):
        return self.to_meshlab(self.default)

    def to_meshlab(self, value):
        """The MeshLab value of a Python value (None -> 0)."""
        if value is None:
            return self.value_type(0)
        return value

    def to_python(self, value):
        """The Python value of a MeshLab or Python value, its type checked (0 -> None where optional).

        Raises
        ------
        ParameterError
            A value of the wrong type or not among the choices.
        """
        if value is None and self.optional:
            return None
        kinds = {bool: (bool, np.bool_), int: numbers.Integral, float: numbers.Real, str: str}
        if not isinstance(value, kinds[self.value_type]) or (
                self.value_type is not bool and isinstance(value, (bool, np.bool_))):
            raise ParameterError(f"{self.name} takes a {self.value_type.__name__} ({self.rich_type}), "
                                 f"got {value!r}")
        value = self.value_type(value)
        if self.choices and value not in self.choices:
            raise ParameterError(f"{self.name} must be one of {', '.join(self.choices)}, got {value!r}")
        if self.optional and value == 0:
            return None
        return value


def _value_type(annotation):
    """``int`` for ``int | None`` and the like."""
    args = [a for a in typing.get_args(annotation) if a is not type(None)]
    return args[0] if args else annotation


def describe_parameters(params_class):
    """The FilterParameters of a parameter dataclass, in field order."""
    out = []
    for f in fields(params_class):
        meta = f.metadata
        value_type = _value_type(f.type)
        out.append(FilterParameter(
            name=f.name,
            rich_type=RICH_TYPES[value_type],
            value_type=value_type,
            default=f.default,
            description=meta["label"],
            tooltip=meta["help"],
            unit=meta.get("unit", ""),
            measure=meta.get("measure", ""),
            choices=meta.get("choices", ()),
            optional=type(None) in typing.get_args(f.type),
            limits=meta.get("limits"),
            summary=meta.get("summary"),
        ))
    return tuple(out)


@dataclass(frozen=True)
class FilterDescription:
    """A skelfilter filter as MeshLab describes a filter; ``apply(mesh, params, progress)`` runs it."""

    name: str  # MeshLab's name, as in .mlx files
    python_name: str  # PyMeshLab-style name of the MeshSet function
    command: str  # the CLI subcommand running it on a file
    layer: str  # name of the layer it adds to a MeshSet
    description: str
    params_class: type
    apply: typing.Callable

    @property
    def parameters(self):
        return describe_parameters(self.params_class)

    def parameter(self, name):
        """The parameter called ``name``; ParameterError naming the filter if there is none."""
        for p in self.parameters:
            if p.name == name:
                return p
        raise ParameterError(f"{self.name} has no parameter {name!r} "
                             f"(its parameters: {', '.join(p.name for p in self.parameters)})")

    def make_params(self, **values):
        """The parameter dataclass from MeshLab or Python values (missing ones take their defaults).

        Raises
        ------
        ParameterError
            Unknown parameter, wrong type, or a value out of range.
        """
        given = {name: self.parameter(name).to_python(value) for name, value in values.items()}
        return self.params_class(**given)


# The mesh pipeline is imported when a filter is applied, not with its description: `skelfilter --help`
# reads the descriptions and needs none of the pipeline's libraries.
def _denoise(mesh, params, progress=None):
    from skelfilter.mesh import pipeline as mesh_pipeline

    return mesh_pipeline.denoise_mesh(mesh, params, progress)


def _noise(mesh, params, progress=None):
    from skelfilter.mesh import pipeline as mesh_pipeline

    return mesh_pipeline.noisy_mesh(mesh, params, progress)[0]


SKELETON_SALIENCY_DENOISE = FilterDescription(
    name="Skeleton Saliency Denoise",
    python_name="apply_skeleton_saliency_denoise",
    command="denoise",
    layer="skeleton denoised",
    description=(
        "Removes small bumps (and dents, with stages both) from a mesh while keeping its sharp edges and "
        "corners, by pruning its surface skeleton (thesis §8.1.1); the result is added as a new layer. "
        "By default (output mesh 'auto') it is the input mesh itself: a clean one comes back as it was, "
        "one with noise finer than the skeleton's scale has its vertices moved by the fine pass (the same "
        "faces, colours and UVs, an open surface stays open); a solid covered in noise at the skeleton's "
        "scale goes through the voxel stage: it is voxelized, skeleton voxels whose streamline importance "
        "rho+ is below t are pruned on the shape (bumps) and on its background (dents), and the "
        "reconstruction becomes a new closed mesh (what output mesh 'closed' always gives)."
    ),
    params_class=DenoiseParams,
    apply=_denoise,
)

ADD_SKELETON_NOISE = FilterDescription(
    name="Add Skeleton Noise",
    python_name="apply_skeleton_noise",
    command="noise",
    layer="skeleton noise",
    description=(
        "Adds the thesis' synthetic noise (§7.2) to a mesh's voxelization: protrusions of height h, "
        "grown by random surface walks of l steps from sites drawn with probability p (and dents, "
        "if asked), meshed by marching cubes into a new layer."
    ),
    params_class=NoiseParams,
    apply=_noise,
)

FILTERS = (SKELETON_SALIENCY_DENOISE, ADD_SKELETON_NOISE)


def find(name):
    """The filter whose MeshLab name, Python name or CLI command is ``name``, or None."""
    for d in FILTERS:
        if name in (d.name, d.python_name, d.command):
            return d
    return None


def _default_text(p):
    value = p.meshlab_default
    text = str(value).lower() if isinstance(value, bool) else str(value)
    return f"{text} (unset)" if p.default is None else text


def text(description):
    """A plain-text listing of a filter and its parameters (``skelfilter filters``)."""
    lines = [f"{description.name}",
             f"  Python: skelfilter.meshlab.meshset.{description.python_name}(ms, **params); "
             f"CLI: skelfilter {description.command}",
             f"  {description.description}"]
    for p in description.parameters:
        choices = f", one of {'/'.join(p.choices)}" if p.choices else ""
        lines.append(f"  {p.name} ({p.rich_type}, default {_default_text(p)}{choices}): "
                     f"{p.description}: {p.full_tooltip}")
    return "\n".join(lines)


def markdown():
    """``docs/filters.md``: every skelfilter filter with its MeshLab-style parameter list."""
    out = ["# skelfilter's filters", "",
           "Generated by `skelfilter filters --markdown` (`make docs`) from the parameter dataclasses "
           "in `skelfilter/params/`; do not edit by hand.", "",
           "Each filter runs from the CLI, on a PyMeshLab `MeshSet` (`skelfilter.meshlab.meshset`) and in a "
           "MeshLab filter script (`skelfilter run-script`), with the parameters below. In .mlx "
           "scripts a parameter's name is its `<Param name>`; 0 leaves a parameter unset where the "
           "default says so (the tooltip tells what unset means). *Measure* tells lengths in voxels "
           "of the grid (absolute) from fractions of the model's longest side (relative).", ""]
    for d in FILTERS:
        out += [f"## {d.name}", "",
                f"Python: `skelfilter.meshlab.meshset.{d.python_name}(ms, **params)` · CLI: "
                f"`skelfilter {d.command}` · .mlx: `<filter name=\"{d.name}\">`", "",
                d.description, "",
                "| name | type | default | description | unit | measure | range | tooltip |",
                "|---|---|---|---|---|---|---|---|"]
        for p in d.parameters:
            choices = f" ({', '.join(p.choices)})" if p.choices else ""
            out.append(f"| `{p.name}` | {p.rich_type}{choices} | {_default_text(p)} | {p.description} | "
                       f"{p.unit or '–'} | {MEASURES.get(p.measure, '–')} | "
                       f"{f'{p.limits[0]:g} to {p.limits[1]:g}' if p.limits else '–'} | {p.tooltip} |")
        out.append("")
    return "\n".join(out)
