"""Parameter fields: the metadata every parameter carries, the range check and the builder that
every entry point goes through (`skelfilter.params` declares the parameters with them)."""

import math
import numbers
from dataclasses import field, fields, replace

import numpy as np

from skelfilter.errors import ParameterError

ABSOLUTE = "absolute"  # a length in voxels of the grid
RELATIVE = "relative"  # a fraction of the longest side of the model's bounding box


def parameter(default, label, help, unit="", choices=None, measure="", limits=None, applies=None, summary=None):
    """A parameter: ``label`` is MeshLab's short name for it, ``help`` its description, ``limits``
    the closed range ``(low, high)`` of a number (checked by `check_limits`), ``applies`` where it
    takes effect, ``{other field: its values}`` (any one of them; checked by `check_applies`).
    ``summary``, in plain words with units, marks one of the few parameters most users set: the CLI's
    ``--help`` shows those, ``--help-all`` every one."""
    meta = {"label": label, "help": help, "unit": unit, "measure": measure}
    if summary is not None:
        meta["summary"] = summary
    if choices is not None:
        meta["choices"] = tuple(choices)
    if limits is not None:
        meta["limits"] = limits
    if applies is not None:
        meta["applies"] = {name: tuple(values) for name, values in applies.items()}
    return field(default=default, metadata=meta)


def limits_of(cls, name):
    """The ``(low, high)`` range of parameter ``name`` of the dataclass ``cls``."""
    return next(f for f in fields(cls) if f.name == name).metadata["limits"]


def check_limits(params):
    """Every number field of a parameter dataclass is a finite number of its type within its
    ``limits`` (None passes where the field allows it); the one check every entry point goes through.
    NumPy numbers (``np.int64(32)``) are taken as the Python numbers they equal, and stored so.

    Raises
    ------
    ParameterError
        Naming the field, its range and the value.
    """
    for f in fields(params):
        limits = f.metadata.get("limits")
        value = getattr(params, f.name)
        if limits is None or value is None:
            continue
        integral = "int" in str(f.type)
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral if integral else numbers.Real):
            raise ParameterError(f"{f.name} must be {'an integer' if integral else 'a number'}, got {value!r}")
        if isinstance(value, np.generic):
            value = value.item()
            object.__setattr__(params, f.name, value)  # a frozen dataclass, being built
        low, high = limits
        if not (math.isfinite(value) and low <= value <= high):
            raise ParameterError(f"{f.name} must be {'an integer' if integral else 'a number'} in "
                                 f"[{low:g}, {high:g}], got {value!r}")


def check_applies(params):
    """A field set away from its default only where it takes effect (its ``applies``).

    Raises
    ------
    ParameterError
        Naming the field and the choices it needs.
    """
    for f in fields(params):
        applies = f.metadata.get("applies")
        if applies is None or getattr(params, f.name) == f.default:
            continue
        if not any(getattr(params, name) in values for name, values in applies.items()):
            needs = " or ".join(f"{name} {'/'.join(values)}" for name, values in applies.items())
            raise ParameterError(f"{f.name} takes effect only with {needs}")


def build(cls, base=None, **values):
    """A ``cls`` (a parameter dataclass) from ``values``, or ``base`` with ``values`` changed.

    Raises
    ------
    ParameterError
        An unknown name, as for any other bad value (not the TypeError of the constructor), or a
        ``base`` that is not a ``cls``.
    """
    known = [f.name for f in fields(cls)]
    unknown = sorted(set(values) - set(known))
    if unknown:
        raise ParameterError(f"unknown parameter{'s' if len(unknown) > 1 else ''} {', '.join(unknown)} "
                             f"(known: {', '.join(known)})")
    if base is None:
        return cls(**values)
    if not isinstance(base, cls):
        hint = f" (a preset by name: preset={base!r})" if isinstance(base, str) else ""
        raise ParameterError(f"params must be a {cls.__name__} or None, got {type(base).__name__}{hint}")
    if not values:
        return base
    return base.with_(**values) if hasattr(base, "with_") else replace(base, **values)


def _type_name(annotation):
    """``float | None`` -> ``float, optional``."""
    text = annotation if isinstance(annotation, str) else getattr(annotation, "__name__", str(annotation))
    parts = [p.strip() for p in str(text).split("|")]
    optional = "None" in parts
    name = " or ".join(p for p in parts if p != "None")
    return f"{name}, optional" if optional else name


def parameter_entries(cls):
    """numpydoc entries, one per field of the parameter dataclass ``cls``: its type, default, label,
    unit, range or choices and description, as the table gives them."""
    lines = []
    for f in fields(cls):
        meta = f.metadata
        if "label" not in meta:
            continue
        bounds = []
        if meta.get("unit"):
            bounds.append(meta["unit"])
        if "limits" in meta:
            bounds.append(f"{meta['limits'][0]:g} to {meta['limits'][1]:g}")
        if "choices" in meta:
            bounds.append("one of " + ", ".join(repr(c) for c in meta["choices"]))
        detail = f" ({'; '.join(bounds)})" if bounds else ""
        lines += [f"{f.name} : {_type_name(f.type)}, default {f.default!r}",
                  f"    {meta['label']}{detail}: {meta['help']}"]
    return lines


def with_parameter_entries(function, cls, indent="    "):
    """``function`` with the fields of ``cls`` (`parameter_entries`) added to its docstring's Parameters
    section, after its own entries: every keyword it takes is documented from the one table."""
    if function.__doc__ is None:  # python -OO
        return function
    lines = function.__doc__.split("\n")
    start = lines.index(f"{indent}Parameters")
    end = next(i for i in range(start + 2, len(lines)) if not lines[i].strip())
    lines[end:end] = [indent + line for line in parameter_entries(cls)]
    function.__doc__ = "\n".join(lines)
    return function
