"""The ``skelfilter`` command; the library never imports it.

`main` holds SIGINT, SIGTERM and SIGHUP from its first line while the libraries load (their native
threads start with them blocked; see :mod:`skelfilter.runtime.signals`), installs the handlers, and
lets the signals in only inside the command's error handling: a signal at any moment after the
interpreter has started ends with one line and exit 128 + its number.
"""


import os
import sys


def main(argv=None):
    from skelfilter.runtime import signals

    signals.block()
    signals.install_handlers()
    from skelfilter.cli.commands import run

    status = run(argv)
    if status:
        _quiet_until_exit()
    return status


def _quiet_until_exit():
    """A failed command has said why in its one line; what the interpreter's shutdown would print
    after it (a compiled library's finalizer of an object an interrupt left half made) goes nowhere."""
    try:
        sys.stderr.flush()
    except (AttributeError, OSError, ValueError):  # no stderr, or a closed one
        pass
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 2)
    os.close(devnull)


__all__ = ["main"]
