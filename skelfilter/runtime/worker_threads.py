"""numba's worker threads, started on purpose: with a tiny parallel kernel, before the pipeline's.

Starting them, numba tries its threading layers in turn; an installed TBB older than numba wants
makes it warn (a ``NumbaWarning``, "The TBB threading layer requires TBB version 2021 update 6 or
later") and use OpenMP, as it would without TBB. That warning says nothing a user of skelfilter can
act on, so the start hides it (and only it) and the entry points start the threads first
(`skelfilter.runtime.signals.start_workers_shielded` for the CLI).
"""

import warnings

import numpy as np
from numba import NumbaWarning, njit, prange


@njit(cache=True, parallel=True)
def _touch(values):
    total = 0.0
    for i in prange(values.size):
        total += values[i]
    return total


def start():
    """Start the threads (the first parallel kernel does), if they have not started."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"(?s).*TBB threading layer", category=NumbaWarning)
        _touch(np.zeros(64))
