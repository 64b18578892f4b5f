"""Step timing, and a one-line-per-step progress display on a terminal."""

import sys
import time
from contextlib import contextmanager, nullcontext

from skelfilter.runtime.signals import deferred


class Progress:
    """Times named steps; prints each on ``stream`` when ``enabled``.

    ``enabled=None`` shows progress only when the stream is a terminal. ``shield``: SIGINT and SIGTERM
    wait until the step they arrive in ends (`skelfilter.runtime.signals.deferred`), which changes the
    process's signal mask for the step: the CLI and the batch workers ask for it, a library call's
    default Progress does not.
    """

    def __init__(self, enabled=None, stream=None, shield=False):
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:
            enabled = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.enabled = enabled
        self.shield = shield
        self.timings = {}
        self.notes = []
        self._prefix = ""

    def note(self, text):
        """Record a line worth telling the user (a choice made for them); printed when enabled."""
        self.notes.append(text)
        if self.enabled:
            self.stream.write(f"  {text}\n")
            self.stream.flush()

    @contextmanager
    def stage(self, name):
        """Prefix the steps run inside with ``name`` (e.g. the pipeline stage)."""
        saved = self._prefix
        self._prefix = f"{saved}{name}/"
        try:
            yield
        finally:
            self._prefix = saved

    @contextmanager
    def step(self, name, shield=True):
        """Time the block as step ``name``; with ``shield`` (and the Progress's) an interrupt waits
        until it ends (`skelfilter.runtime.signals.deferred`): leave it off for steps that wait on child
        processes."""
        key = self._prefix + name
        if self.enabled:
            self.stream.write(f"  {key} ...")
            self.stream.flush()
        start = time.perf_counter()
        try:
            with deferred() if shield and self.shield else nullcontext():
                yield
        except BaseException:
            if self.enabled:
                self.stream.write(" stopped\n")
                self.stream.flush()
            raise
        elapsed = time.perf_counter() - start
        self.timings[key] = self.timings.get(key, 0.0) + elapsed
        if self.enabled:
            self.stream.write(f" {elapsed:.2f} s\n")
            self.stream.flush()
