"""What compiled libraries print on the process's standard output and error (open3d's readers,
PoissonRecon's warnings), caught so that a run says only its own lines and an error stays one line."""

import contextlib
import os
import re
import sys
import tempfile


@contextlib.contextmanager
def captured():
    """What C libraries (open3d and its PLY reader) print while the block runs, on the standard output
    or error, goes to a file instead; the function yielded reads it back as its non-empty lines,
    stripped and without terminal colour codes: an error stays one line."""
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:  # None: the command was started with it closed
            stream.flush()
    saved = [_duplicate(1), _duplicate(2)]
    with tempfile.TemporaryFile() as sink:
        os.dup2(sink.fileno(), 1)
        os.dup2(sink.fileno(), 2)
        try:
            yield lambda: _lines((sink.seek(0), sink.read().decode("utf-8", "replace"))[1])
        finally:
            for fd, copy in zip((1, 2), saved):
                if copy is None:  # closed before: closed again
                    os.close(fd)
                else:
                    os.dup2(copy, fd)
                    os.close(copy)


def _duplicate(fd):
    """A copy of the descriptor ``fd``, or None where it is closed."""
    try:
        return os.dup(fd)
    except OSError:
        return None


def _lines(text):
    """The non-empty lines of ``text``, stripped, without terminal colour codes."""
    return [line.strip() for line in re.sub(r"\x1b\[[0-9;]*m", "", text).splitlines() if line.strip()]
