"""Step timing, and a one-line-per-step progress display on a terminal."""

import os
import sys
import time
from contextlib import contextmanager, nullcontext

from .signals import deferred

# hidden hook for the interrupt tests: the step of this name (with its stage prefix) announces itself
# on stderr and waits, so a test can signal the process inside any step
_PAUSE_ENV = "_SKELFILTER_PAUSE_STEP"


class Progress:
    """Times named steps; prints each on ``stream`` when ``enabled``.

    ``enabled=None`` shows progress only when the stream is a terminal.
    """

    def __init__(self, enabled=None, stream=None):
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:
            enabled = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.enabled = enabled
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
        """Time the block as step ``name``; with ``shield`` an interrupt waits until it ends
        (`skelfilter.signals.deferred`): leave it off for steps that wait on child processes."""
        key = self._prefix + name
        if self.enabled:
            self.stream.write(f"  {key} ...")
            self.stream.flush()
        start = time.perf_counter()
        try:
            with deferred() if shield else nullcontext():
                if os.environ.get(_PAUSE_ENV) == key:
                    sys.stderr.write(f"paused in {key}\n")
                    sys.stderr.flush()
                    time.sleep(1)
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
