"""The ``skelfilter`` command; the library never imports it.

`main` holds SIGINT, SIGTERM and SIGHUP from its first line while the libraries load (their native
threads start with them blocked; see :mod:`skelfilter.runtime.signals`), installs the handlers, and
lets the signals in only inside the command's error handling: a signal at any moment after the
interpreter has started ends with one line and exit 128 + its number.
"""


def main(argv=None):
    from skelfilter.runtime import signals

    signals.block()
    signals.install_handlers()
    from skelfilter.cli.commands import run

    return run(argv)


__all__ = ["main"]
