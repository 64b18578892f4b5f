"""Faults injected from the outside, for the tests (none of this is in the shipped code).

Run skelfilter's CLI with one: ``python tests/harness.py FAULT ARGUMENT -- CLI-ARGUMENTS``.

- ``pause STEP``: the progress step of this name (with its stage prefix, e.g.
  ``foreground/importance``) says ``paused in STEP`` on stderr and waits a second inside its shielded
  block, so that a test can signal the process inside any step;
- ``meshlab ACTION[@N]``: the pymeshlab child process of `skelfilter.meshlab.pymeshlab_filters.run_filters`
  aborts (``abort``) or hangs (``sleep``) before its step N (default 0);
- ``batch-kill NAME``: the batch worker that takes the input file named NAME kills itself.

The child processes that these faults reach import this module, so its folder must be on their
``PYTHONPATH`` (`with_harness_path`).
"""

import contextlib
import os
import sys
import time

from distributed.diagnostics.plugin import WorkerPlugin

HERE = os.path.dirname(os.path.abspath(__file__))
FAULT_FILE = "fault"  # in the MeshLab child's work folder: the action and the step


def with_harness_path(env):
    """``env`` with this folder leading ``PYTHONPATH``."""
    return {**env, "PYTHONPATH": os.pathsep.join(p for p in (HERE, env.get("PYTHONPATH")) if p)}


def pause_in(key):
    from skelfilter.runtime import progress

    original = progress.Progress.step

    @contextlib.contextmanager
    def step(self, name, shield=True):
        with original(self, name, shield):
            if self._prefix + name == key:
                sys.stderr.write(f"paused in {key}\n")
                sys.stderr.flush()
                time.sleep(1)
            yield

    progress.Progress.step = step


def meshlab_child_fault(action, patch=None):
    """Start the MeshLab children with `faulty_meshlab_child`; ``patch(module, name, value)`` sets the
    attribute (pytest's ``monkeypatch.setattr``; a plain setattr by default)."""
    from skelfilter.meshlab import pymeshlab_filters

    original = pymeshlab_filters.run_child

    def run_child(module, function, workdir, timeout, what):
        with open(os.path.join(workdir, FAULT_FILE), "w", encoding="utf-8") as f:
            f.write(action)
        return original("harness", "faulty_meshlab_child", workdir, timeout, what)

    (patch or setattr)(pymeshlab_filters, "run_child", run_child)


def faulty_meshlab_child(workdir):
    """The MeshLab child's entry point with its fault: the step'th filter aborts or hangs."""
    from skelfilter.meshlab import pymeshlab_filters

    with open(os.path.join(workdir, FAULT_FILE), encoding="utf-8") as f:
        action, _, at = f.read().partition("@")
    calls = [0]
    original = pymeshlab_filters.apply_filter

    def apply_filter(ms, name, params):
        if calls[0] == int(at or 0):
            if action == "abort":
                os.abort()
            time.sleep(3600)
        calls[0] += 1
        return original(ms, name, params)

    pymeshlab_filters.apply_filter = apply_filter
    pymeshlab_filters._child_main(workdir)


class KillOnInput(WorkerPlugin):
    """In every batch worker: the task of the input file named ``name`` kills its worker."""

    def __init__(self, name):
        self.name = name

    def setup(self, worker):
        from skelfilter.jobs import batch

        original, name = batch._task, self.name

        def task(input_path, *args, **kwargs):
            if os.path.basename(input_path) == name:
                os.kill(os.getpid(), 9)
            return original(input_path, *args, **kwargs)

        batch._task = task


def kill_batch_worker_on(name):
    from skelfilter.jobs import batch

    original = batch.local_cluster

    def local_cluster(*args, **kwargs):
        client, threads = original(*args, **kwargs)
        client.register_plugin(KillOnInput(name))
        return client, threads

    batch.local_cluster = local_cluster


FAULTS = {"pause": pause_in, "meshlab": meshlab_child_fault, "batch-kill": kill_batch_worker_on}

if __name__ == "__main__":
    fault, argument, separator, *cli_arguments = sys.argv[1:]
    assert separator == "--", "usage: harness.py FAULT ARGUMENT -- CLI-ARGUMENTS"
    from skelfilter.runtime import signals

    signals.block()  # as skelfilter.cli.main does first: the faults' imports start threads with the signals held
    from skelfilter.cli import main

    FAULTS[fault](argument)
    sys.exit(main(cli_arguments))
