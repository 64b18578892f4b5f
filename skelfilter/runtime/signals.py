"""Interrupts between pipeline steps, never inside numba's parallel kernels.

A SIGINT or SIGTERM arriving while numba's OpenMP kernels run (the A* of the geodesic importance
above all) crashed the process with a segmentation fault. So the worker threads are started with
both signals blocked (threads inherit the mask of the thread that starts them), and each pipeline
step runs with them blocked in the main thread too (`deferred`): a signal waits until the step ends,
then Python raises and the run ends as any interrupted one (one line, exit 130 or 143, no output).
"""

import signal
from contextlib import contextmanager

import numpy as np
from numba import njit, prange

SIGNALS = {signal.SIGINT, signal.SIGTERM}


@njit(cache=True, parallel=True)
def _touch(values):
    total = 0.0
    for i in prange(values.size):
        total += values[i]
    return total


def start_workers_shielded():
    """Start numba's worker threads with SIGINT and SIGTERM blocked in them (see the module)."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    try:
        _touch(np.zeros(64))
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


@contextmanager
def deferred():
    """SIGINT and SIGTERM wait until the block ends, then act (Python raises right after).

    An interrupt that arrived while numba's OpenMP kernels ran in this thread crashed the process
    (``geodesic_importance``'s A*: a segmentation fault in the main thread); a pipeline step is
    therefore never interrupted inside, only between steps.
    """
    old = signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
