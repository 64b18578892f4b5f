"""numba's worker threads, started on purpose: with a tiny parallel kernel, before the pipeline's.

Starting them, numba tries its threading layers in turn; an installed TBB older than numba wants
makes it warn (a ``NumbaWarning``, "The TBB threading layer requires TBB version 2021 update 6 or
later") and use OpenMP, as it would without TBB. That warning says nothing a user of skelfilter can
act on, so the start hides it (and only it).

The threads start with SIGINT, SIGTERM and SIGHUP blocked (threads inherit the mask of the thread
that starts them): a signal always reaches the main thread, never a worker inside a kernel (see
:mod:`skelfilter.runtime.signals`). Each entry point starts them just before its first parallel
kernel, so that a run that decides there is nothing to do never pays for them.

A threading layer the user chose (``NUMBA_THREADING_LAYER``) that numba cannot start (``tbb`` where
TBB is not installed) is refused in one line naming the variable; it is not replaced by another
behind the user's back.
"""

import warnings

import numba
import numpy as np
from numba import NumbaWarning, prange

from skelfilter.errors import ParameterError
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
    have not started (`skelfilter.runtime.signals.deferred`: a signal acts once they have).

    Raises
    ------
    ParameterError
        ``NUMBA_THREADING_LAYER`` names a layer numba cannot start here (unknown, or its library is
        not installed).
    """
    with signals.deferred(), warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=r"(?s).*TBB threading layer", category=NumbaWarning)
        try:
            _touch(np.zeros(64))
        except ValueError as exc:  # numba's, as it launches the layer it was told to
            chosen = numba.config.THREADING_LAYER
            if chosen == "default":
                raise
            reason = " ".join(str(exc).replace("HINT:", "").split()).rstrip(".")
            raise ParameterError(f"NUMBA_THREADING_LAYER={chosen}: numba cannot start this threading layer "
                                 f"({reason}); install what it needs, or unset NUMBA_THREADING_LAYER to let "
                                 "numba choose") from None
