"""Experiments: one-off research that informed a decision, kept so that its figures in the design record
(``docs/design/``) reproduce. Run from the repository's root as ``python -m experiments.<name>``; they
use the benchmark harness (:mod:`benchmarks`), never the other way round, and the product's tests do not
import them (their smoke tests are in ``experiments/tests``).
"""
