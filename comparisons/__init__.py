"""The side-by-side comparison of skelfilter with MeshLab's filters (``skelfilter compare``).

:mod:`~comparisons.config` reads the TOML configuration, :mod:`~comparisons.methods` runs one method,
:mod:`~comparisons.run` runs and measures everything, :mod:`~comparisons.render` draws the pictures
and :mod:`~comparisons.report` writes ``report.html`` and ``report.md``.
"""
