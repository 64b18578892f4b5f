"""The optional dependencies: each comes with one of the package's extras, and a missing one is
refused in one line that names the extra to install."""

import importlib

from skelfilter.errors import SkelfilterError
from skelfilter.runtime.signals import deferred

# The extra (pyproject.toml's optional-dependencies) that installs each optional top-level module.
EXTRA_OF = {
    "pymeshlab": "meshlab",
    "nibabel": "volumes",
    "nrrd": "volumes",
    "tifffile": "volumes",
    "dask": "batch",
    "distributed": "batch",
    "meshlib": "compare",
    "pyvista": "compare",
    "pygel3d": "compare",
    "PIL": "compare",
}
# What `skelfilter compare` runs: checked before it starts, not when the first method needs it.
COMPARE_MODULES = ("pymeshlab", "meshlib.mrmeshpy", "pygel3d", "pyvista", "PIL")


class MissingExtra(SkelfilterError):
    """An optional dependency is not installed."""


def need(module, purpose, extra=None):
    """Import the optional ``module`` (e.g. ``"pymeshlab"``, ``"meshlib.mrmeshpy"``); ``extra``: the
    extra to name when missing, if not the module's own (`EXTRA_OF`).

    Raises
    ------
    MissingExtra
        The module is not installed: the message names ``purpose`` (what needs it) and the extra.
        A module that is installed but fails to load raises its own error.

    Examples
    --------
    >>> need("numpy", "anything").__name__
    'numpy'
    """
    top = module.split(".")[0]
    try:
        return load(module)
    except ModuleNotFoundError as exc:
        if exc.name is None or exc.name.split(".")[0] != top:
            raise
        extra = extra or EXTRA_OF[top]
        raise MissingExtra(f"{purpose}: {top} is not installed; it comes with skelfilter's '{extra}' "
                           f"extra: pip install 'skelfilter[{extra}]'") from None


def load(module):
    """Import ``module`` with SIGINT, SIGTERM and SIGHUP held until it is loaded.

    An interrupt inside the import of a compiled library leaves it half initialised: open3d's then
    turned the process's exit status into 1 on its way out (the run had said "interrupted", exit 130),
    VTK's crashed it. Held, the interrupt acts as the import ends.
    """
    with deferred():
        return importlib.import_module(module)
