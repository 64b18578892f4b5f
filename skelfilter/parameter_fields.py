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
