"""The ``skelfilter`` command; the library never imports it."""

from skelfilter.cli.commands import main

__all__ = ["main"]
