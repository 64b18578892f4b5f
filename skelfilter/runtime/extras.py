"""The optional dependencies: each comes with one of the package's extras, and a missing one is
refused in one line that names the extra to install."""

import importlib
import resource

from skelfilter.errors import ResourceError, SkelfilterError
from skelfilter.runtime.signals import deferred

# The extra (pyproject.toml's optional-dependencies) that installs each optional top-level module.
EXTRA_OF = {
    "pymeshlab": "meshlab",
    "open3d": "clouds",
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
    ResourceError
        The module is installed but the memory or address space is too short to load it (`load`).
        A module that is installed but fails to load otherwise raises its own error.

    Examples
    --------
    >>> need("numpy", "anything").__name__
    'numpy'
    """
    top = module.split(".")[0]
    try:
        return load(module)
    except ResourceError as exc:
        raise ResourceError(f"{purpose}: {exc}") from None
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

    Raises
    ------
    ResourceError
        The module's compiled libraries could not be mapped into memory: the system's loader says
        "failed to map segment" when the memory, or the address space a limit allows (``ulimit -v``:
        open3d's library alone is 800 MB), is short. The message names the module and the limit.
    """
    with deferred():
        try:
            return importlib.import_module(module)
        except ImportError as exc:
            if "failed to map segment" not in str(exc):
                raise
            raise ResourceError(f"{module.split('.')[0]} could not be loaded: not enough memory or address space "
                                f"for its libraries ({_address_space_limit()}); raise the limit, or free memory") \
                from None


def _address_space_limit():
    """The process's limit on its address space, in words."""
    limit_bytes = resource.getrlimit(resource.RLIMIT_AS)[0]
    if limit_bytes == resource.RLIM_INFINITY:
        return "no address space limit is set: the memory is short"
    return f"the address space is limited to {limit_bytes / 2**30:.2g} GiB: ulimit -v"
