"""numba's ``njit`` for every compiled kernel: cached on disk where numba can write its cache, and
compiled (or loaded from the cache) with SIGINT, SIGTERM and SIGHUP held.

numba keeps compiled kernels beside the source (``__pycache__``) or in the user's cache folder
(``NUMBA_CACHE_DIR``). A system install run by an account that can write neither (a service
account without a home) made ``cache=True`` fail at import; there the kernels are compiled in the
process instead, each run paying the compilation.

A kernel's first call in a process compiles it or loads it from the cache, and LLVM calls back into
Python meanwhile (ctypes callbacks). A signal handler that raised inside one of them (the CLI's
`Interrupted`, or Python's own ``KeyboardInterrupt``) left LLVM half done, and the process crashed
with a segmentation fault instead of saying "terminated" (``skelfilter compare`` interrupted while
it made its noisy mesh). Held, the signal acts once the kernel is ready
(`skelfilter.runtime.signals.deferred`); the thread's signal mask is as it was afterwards.
"""

import functools

import numba

from skelfilter.runtime.signals import deferred


def njit(**options):
    """``numba.njit(cache=True, **options)``, or without the cache where numba has none to write;
    the dispatcher compiles with the signals held."""

    def compile_(function):
        try:
            dispatcher = numba.njit(cache=True, **options)(function)
        except RuntimeError as exc:
            if "cannot cache" not in str(exc):
                raise
            dispatcher = numba.njit(**options)(function)
        return _compiling_with_signals_held(dispatcher)

    return compile_


def _compiling_with_signals_held(dispatcher):
    # numba compiles (or loads) every signature through the dispatcher's own ``compile``, whether the
    # kernel is called from Python or from another kernel.
    compile_signature = dispatcher.compile

    @functools.wraps(compile_signature)
    def compile_held(signature):
        with deferred():
            return compile_signature(signature)

    dispatcher.compile = compile_held
    return dispatcher
