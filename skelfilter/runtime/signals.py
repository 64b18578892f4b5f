"""Interrupts: between pipeline steps, never inside numba's parallel kernels; in the CLI, at any
moment, one line and exit 128 + the signal's number.

A SIGINT or SIGTERM arriving while numba's OpenMP kernels run (the A* of the geodesic importance
above all) crashed the process with a segmentation fault. So the worker threads are started with
the signals blocked (threads inherit the mask of the thread that starts them), and each pipeline
step runs with them blocked in the main thread too (`deferred`): a signal waits until the step ends,
then Python raises and the run ends as any interrupted one (one line, no output).

The CLI (`install_handlers`) turns SIGINT, SIGTERM and SIGHUP into `Interrupted`, raised where
Python is, so that every ``finally`` and ``with`` cleans up (children, temporary files). A signal
the command's parent chose to ignore (``nohup``, a background job) stays ignored. The first
signal blocks the others, so a second Ctrl-C cannot break the cleanup of the first.
"""

import shutil
import signal
import tempfile
import threading
from contextlib import contextmanager

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
WORDS = {signal.SIGINT: "interrupted", signal.SIGTERM: "terminated", signal.SIGHUP: "hung up"}


class Interrupted(KeyboardInterrupt):
    """A SIGINT, SIGTERM or SIGHUP, raised in the main thread by the CLI's handlers."""

    def __init__(self, signum):
        super().__init__(signum)
        self.signum = signum

    @property
    def word(self):
        return WORDS.get(self.signum, "interrupted")

    @property
    def exit_status(self):
        return 128 + self.signum


# Inside `deferred` blocks (their depth) a signal the handler sees is kept here, raised as the
# outermost block ends.
_held = {"depth": 0, "signum": None}


def _raise(signum, frame):
    signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    if _held["depth"]:
        _held["signum"] = _held["signum"] or signum
        return
    raise Interrupted(signum)


def block():
    """Hold SIGINT, SIGTERM and SIGHUP in this thread; returns the previous mask."""
    return signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)


def unblock():
    """Let SIGINT, SIGTERM and SIGHUP in (one pending is delivered now)."""
    signal.pthread_sigmask(signal.SIG_UNBLOCK, SIGNALS)


def install_handlers():
    """The CLI's handlers (process-wide: a command's choice, never a library call's): each signal
    that is not ignored raises `Interrupted`."""
    for signum in SIGNALS:
        if signal.getsignal(signum) is not signal.SIG_IGN:
            signal.signal(signum, _raise)


def ignore_from_now():
    """The CLI's last word: the command has its status, and a signal from here to the exit (whichever
    thread it reaches, while the interpreter shuts down and restores the default actions) is ignored."""
    for signum in SIGNALS:
        signal.signal(signum, signal.SIG_IGN)


@contextmanager
def deferred():
    """SIGINT, SIGTERM and SIGHUP wait until the block ends, then act (Python raises right after).

    An interrupt that arrived while numba's OpenMP kernels ran in this thread crashed the process
    (``geodesic_importance``'s A*: a segmentation fault in the main thread); a pipeline step is
    therefore never interrupted inside, only between steps. A signal that reached the CLI's handler
    just before the block (Python runs the handler at its next instruction, which may be inside) is
    held too: an interrupt inside an import of VTK's modules left them half loaded, and the process
    crashed on its way out.

    Blocking the signals in this thread is not enough where the handlers are the caller's (a library
    call: Python's ``KeyboardInterrupt``, a notebook's): the signal reaches another thread that does
    not block it (a BLAS thread), and Python runs the handler in the main thread at its next
    instruction, wherever that is, numba's return from a kernel among them. So in the main thread the
    caller's handlers are lent to `_raise` for the block, which keeps the signal; as the block ends
    they are back, and the signal is raised again for them to act on as it came.
    """
    old = block()
    _held["depth"] += 1
    lent = {}
    acted = False
    try:
        _lend_handlers(lent)
        yield
    except Interrupted:
        acted = True  # at a `checkpoint`: the handler left the signals blocked, and they stay so
        raise
    finally:
        if lent:
            _give_back(lent, old)
        _held["depth"] -= 1
        if not lent and _held["depth"] == 0 and _held["signum"] is not None:
            signum, _held["signum"] = _held["signum"], None
            raise Interrupted(signum)  # the handler left the signals blocked, as it does when it raises
        if not acted and not lent:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _lend_handlers(lent):
    """In the main thread, put `_raise` in the place of the caller's Python handlers; ``lent`` gets
    each one replaced, by signal. Handlers that are not Python's (the default action, an ignored
    signal, one set in C) stay."""
    if threading.current_thread() is not threading.main_thread():
        return
    for signum in SIGNALS:
        handler = signal.getsignal(signum)
        if callable(handler) and handler is not _raise:
            signal.signal(signum, _raise)
            lent[signum] = handler


def _give_back(lent, old):
    """The caller's handlers and signal mask back; a signal `_raise` kept meanwhile is raised again,
    so that the caller's handler acts on it now."""
    for signum, handler in lent.items():
        signal.signal(signum, handler)  # runs `_raise` first for a signal that just came: it is kept
    signum, _held["signum"] = _held["signum"], None
    signal.pthread_sigmask(signal.SIG_SETMASK, old)
    if signum is not None:
        signal.raise_signal(signum)


def checkpoint():
    """Inside a `deferred` block, between two kernels of a long step (the iterations of a filter): a
    signal held so far acts now, instead of when the step ends (a fine pass on millions of faces held
    a SIGTERM for minutes). Outside one, or with no signal held, nothing happens."""
    if not _held["depth"]:
        return
    if _held["signum"] is None and set(SIGNALS) & signal.sigpending():
        # Let the waiting signal in: the handler keeps it (and blocks the signals again), or a caller
        # without the CLI's handlers gets Python's own action, as at the block's end.
        signal.pthread_sigmask(signal.SIG_UNBLOCK, SIGNALS)
        signal.pthread_sigmask(signal.SIG_BLOCK, SIGNALS)
    if _held["signum"] is not None:
        signum, _held["signum"] = _held["signum"], None
        raise Interrupted(signum)


@contextmanager
def temporary_folder(prefix, directory=None):
    """A temporary folder, made and removed with the signals held, so that an interrupt at any
    moment leaves none behind."""
    with deferred():
        folder = tempfile.mkdtemp(prefix=prefix, dir=directory)
    try:
        yield folder
    finally:
        with deferred():
            shutil.rmtree(folder, ignore_errors=True)
