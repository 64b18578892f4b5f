"""Measuring results: the metrics, figures, and the side-by-side comparison with MeshLab's and
other filters (:mod:`skelfilter.evaluation.comparison`)."""
