"""numba's ``njit`` for every compiled kernel: cached on disk where numba can write its cache;
compiled (or loaded from the cache), and called from the main thread, with SIGINT, SIGTERM and SIGHUP
held.

numba keeps compiled kernels beside the source (``__pycache__``) or in the user's cache folder
(``NUMBA_CACHE_DIR``). A system install run by an account that can write neither (a service
account without a home) made ``cache=True`` fail at import; there the kernels are compiled in the
process instead, each run paying the compilation.

A kernel's first call in a process compiles it or loads it from the cache, and LLVM calls back into
Python meanwhile (ctypes callbacks). A signal handler that raised inside one of them (the CLI's
`Interrupted`, or Python's own ``KeyboardInterrupt``) left LLVM half done, and the process crashed
with a segmentation fault instead of saying "terminated" (``skelfilter compare`` interrupted while
it made its noisy mesh).

A signal that arrives while a kernel runs is handled as numba turns its results into Python objects:
Python code that runs meanwhile (a garbage collection's finalizers) raises ``KeyboardInterrupt``
there, and numba does not look. A kernel that returns a tuple of arrays then came back as
``SystemError: CPUDispatcher(astar) returned a result with an exception set``, or with a tuple
already freed, and the interpreter crashed (Ctrl-C in a notebook during the geodesic search). So a
call from the main thread, the only one where Python handles signals, holds them too.

Held, the signal acts once the kernel is ready or has returned
(`skelfilter.runtime.signals.deferred`); the thread's signal mask is as it was afterwards.
"""

import threading

import numba
from numba.core.registry import CPUDispatcher

from skelfilter.runtime.signals import deferred


def njit(**options):
    """``numba.njit(cache=True, **options)``, or without the cache where numba has none to write;
    the dispatcher compiles, and runs when called from the main thread, with the signals held."""

    def compile_(function):
        try:
            dispatcher = numba.njit(cache=True, **options)(function)
        except RuntimeError as exc:
            if "cannot cache" not in str(exc):
                raise
            dispatcher = numba.njit(**options)(function)
        dispatcher.__class__ = HeldKernel
        return dispatcher

    return compile_


class HeldKernel(CPUDispatcher):
    """numba's dispatcher, holding the signals while it compiles a signature (from whatever thread,
    and from Python or another kernel: numba compiles every signature through ``compile``) and while
    a call from Python in the main thread runs. Kernels calling kernels do not pass by ``__call__``."""

    def compile(self, sig):
        with deferred():
            return super().compile(sig)

    def __call__(self, *args, **kwargs):
        if threading.current_thread() is not threading.main_thread():
            return super().__call__(*args, **kwargs)
        with deferred():
            return super().__call__(*args, **kwargs)
