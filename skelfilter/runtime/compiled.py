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

numba's GNU OpenMP threading layer (the one it picks on Linux where TBB is not installed) cannot run
in a child forked after it started: numba kills such a child (SIGTERM) at its first parallel kernel,
and ``multiprocessing``'s 'fork' start method forks so. There a parallel kernel runs its serial twin,
the same function compiled without ``parallel`` (one thread per process, as a pool of processes
wants). The threading layer itself stays numba's or the user's choice: the fork-safe ``workqueue``
is not thread-safe (two threads running kernels at once abort the process).
"""

import os
import threading
import types

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
    a call from Python in the main thread runs; a parallel kernel called in a child forked from a
    process running GNU OpenMP runs its serial twin. Kernels calling kernels do not pass by
    ``__call__``."""

    def compile(self, sig):
        with deferred():
            return super().compile(sig)

    def __call__(self, *args, **kwargs):
        kernel = super().__call__
        if _forked["after_gnu_openmp"] and self.targetoptions.get("parallel"):
            kernel = self._serial_twin()
        if threading.current_thread() is not threading.main_thread():
            return kernel(*args, **kwargs)
        with deferred():
            return kernel(*args, **kwargs)

    def _serial_twin(self):
        """The kernel compiled without ``parallel`` (``prange`` runs as ``range``), made at its first
        use. It is compiled from a copy of the function under a name of its own: numba's cache tells
        kernels apart by name and code, not by options, and would give the twin the parallel code."""
        twin = self.__dict__.get("serial_twin")
        if twin is None:
            function = self.py_func
            copy = types.FunctionType(function.__code__, function.__globals__, function.__name__,
                                      function.__defaults__, function.__closure__)
            copy.__qualname__ = f"{function.__qualname__}_serial"
            options = {name: value for name, value in self.targetoptions.items()
                       if name not in ("parallel", "nopython")}
            twin = self.__dict__["serial_twin"] = njit(**options)(copy)
        return twin


# Whether this process was forked from one whose numba threads ran on GNU OpenMP (or from a child of one).
_forked = {"after_gnu_openmp": False}


def _gnu_openmp_started():
    """Whether numba's threads have started, on GNU OpenMP."""
    try:
        layer = numba.threading_layer()
    except ValueError:  # no parallel kernel has run: no threads yet
        return False
    if layer != "omp":
        return False
    from numba.np.ufunc import omppool

    return omppool.openmp_vendor == "GNU"


def _note_fork():
    _forked["after_gnu_openmp"] = _forked["after_gnu_openmp"] or _gnu_openmp_started()


# Only skelfilter's own note, in the child: the process's behaviour is not changed.
os.register_at_fork(after_in_child=_note_fork)
