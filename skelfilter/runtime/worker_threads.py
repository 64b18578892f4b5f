"""numba's worker threads, started on purpose: with a tiny parallel kernel, before the pipeline's.

Starting them, numba tries its threading layers in turn; an installed TBB older than numba wants
makes it warn (a ``NumbaWarning``, "The TBB threading layer requires TBB version 2021 update 6 or
later") and use OpenMP, as it would without TBB. That warning says nothing a user of skelfilter can
act on, so the start hides it (and only it).

The threads start with SIGINT, SIGTERM and SIGHUP blocked (threads inherit the mask of the thread
that starts them): a signal always reaches the main thread, never a worker inside a kernel (see
:mod:`skelfilter.runtime.signals`). Each entry point starts them just before its first parallel
kernel, so that a run that decides there is nothing to do never pays for them.
"""

import warnings

import numpy as np
from numba import NumbaWarning, prange

from skelfilter.runtime import signals
from skelfilter.runtime.compiled import njit


@njit(parallel=True)
def _touch(values):
    total = 0.0
    for i in prange(values.size):
        total += values[i]
    return total


def start():
    """Start the threads (the first parallel kernel does) with the signals blocked in them, if they
    have not started (`skelfilter.runtime.signals.deferred`: a signal acts once they have)."""
    with signals.deferred(), warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"(?s).*TBB threading layer", category=NumbaWarning)
        _touch(np.zeros(64))
