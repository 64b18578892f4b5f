"""Running C++ libraries that can crash (pymeshlab, MeshLib) in a child Python process.

A segmentation fault, an abort or a hang in the child becomes a :class:`SkelfilterError` naming what
ran, instead of taking the caller down. A child dies with its parent: on an interrupt or a SIGTERM
the parent kills it (``subprocess.run`` does on any exception) and its temporary folder goes; if the
parent is killed outright, Linux kills the child (``PR_SET_PDEATHSIG``).
"""

import ctypes
import os
import signal
import subprocess
import sys

from skelfilter.errors import SkelfilterError


def signal_text(code):
    """``Aborted (signal 6)`` for signal number 6, and so on."""
    try:
        return f"{signal.strsignal(code) or signal.Signals(code).name} (signal {code})"
    except (ValueError, AttributeError):
        return f"signal {code}"


_PR_SET_PDEATHSIG = 1


def _die_with_parent():
    """In the child, before it runs: have Linux kill it when its parent dies, however the parent dies
    (a SIGKILL included), so no child is ever left running alone."""
    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
    except OSError:  # not Linux/glibc: the parent's cleanup still kills the child
        return
    libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)


def _name(what):
    return what() if callable(what) else what


def run_child(module, function, workdir, timeout, what):
    """Call ``module.function(workdir)`` in a fresh Python process and wait for it.

    The child imports this checkout's packages first (its parent folder leads ``PYTHONPATH``).

    ``what`` names what ran in the messages: a string, or a function giving it after a failure
    (it may read what the child left in ``workdir``).

    Returns
    -------
    subprocess.CompletedProcess
        With captured stdout and stderr; a non-zero exit status is the caller's to read.

    Raises
    ------
    SkelfilterError
        ``"{what} did not finish within … s"`` (the child is killed) or ``"{what} crashed: <signal>"``.
    """
    package_parent = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (package_parent, env.get("PYTHONPATH")) if p)
    cmd = [sys.executable, "-c", f"import sys; from {module} import {function}; {function}(sys.argv[1])", workdir]
    try:
        proc = subprocess.run(cmd, env=env, stdin=subprocess.DEVNULL, capture_output=True, timeout=timeout,
                              preexec_fn=_die_with_parent)
    except subprocess.TimeoutExpired:
        raise SkelfilterError(f"{_name(what)} did not finish within {timeout:g} s; the child process was "
                              "killed") from None
    if proc.returncode < 0:
        raise SkelfilterError(f"{_name(what)} crashed: {signal_text(-proc.returncode)}")
    return proc
