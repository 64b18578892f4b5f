"""The sample meshes shipped with the package (``skelfilter/data``; sources in its README)."""

from importlib import resources


def sample_path(name="fandisk"):
    """Path of an embedded clean sample mesh: ``fandisk`` (H. Hoppe's fandisk), ``rocker-arm``,
    ``spot`` or ``stanford-bunny``."""
    path = resources.files("skelfilter") / "data" / f"{name}.obj"
    if not path.is_file():
        raise FileNotFoundError(f"no sample mesh named {name!r}")
    return str(path)
