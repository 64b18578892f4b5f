"""The benchmark harness: what chose the default and what measures it, run from the repository's root
as ``python -m benchmarks.<name>``.

- Quality: `benchmarks.quality` (the quality benchmark: shapes x noise kinds x seeds, skelfilter's
  variants against MeshLab's and others' filters, the held-out split reported apart; tables by
  `benchmarks.quality_tables`), `benchmarks.oracle` (the per-ball oracle it reports as the ceiling),
  `benchmarks.shapes` (the benchmark's clean shapes), `benchmarks.volumes` (segmentation-like noise on
  volumes), `benchmarks.surfaces` (surfaces from masks against VTK's and Slicer's), `benchmarks.literature`
  (the field's noisy/clean pairs), `benchmarks.point_clouds`, `benchmarks.routing` with
  `benchmarks.routing_corpus` (what the default runs on each kind of input; depth-camera scans by
  `benchmarks.depth_scan` and `benchmarks.range_scan`), `benchmarks.comparison_tables`.
- The thesis: `benchmarks.thesis_tables` (its tables and figures reproduced), `benchmarks.acceptance`.
- Time and memory: `benchmarks.bench_pipeline`, `benchmarks.thread_scaling`, `benchmarks.batch` (Dask
  workers), `benchmarks.label_cost`; `benchmarks.same_outputs` (one commit's outputs against another's,
  bit for bit).

One-off research lives apart, in ``experiments/``; nothing here imports it.
"""
