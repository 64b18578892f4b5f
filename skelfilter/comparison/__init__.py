"""The side-by-side comparison of skelfilter with MeshLab's filters (``skelfilter compare``).

:mod:`~skelfilter.comparison.config` reads the TOML configuration,
:mod:`~skelfilter.comparison.methods` runs one method,
:mod:`~skelfilter.comparison.run` runs and measures everything, :mod:`~skelfilter.comparison.render` draws the pictures
and :mod:`~skelfilter.comparison.report` writes ``report.html`` and ``report.md``.
"""
