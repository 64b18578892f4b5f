"""The side-by-side comparison of skelfilter with MeshLab's filters (``skelfilter compare``).

:mod:`~skelfilter.evaluation.comparison.config` reads the TOML configuration,
:mod:`~skelfilter.evaluation.comparison.methods` runs one method,
:mod:`~skelfilter.evaluation.comparison.run` runs and measures everything,
:mod:`~skelfilter.evaluation.comparison.render` draws the pictures and
:mod:`~skelfilter.evaluation.comparison.report` writes ``report.html`` and ``report.md``.
"""
