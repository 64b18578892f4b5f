"""Many files at once on Dask distributed: ``skelfilter batch`` and `denoise_many`.

Each input file is one task (:func:`skelfilter.jobs.denoise_file.denoise_file`) on a Dask cluster: a
``LocalCluster`` of single-threaded worker processes by default, each running numba on its share of
the cores, so Dask's processes and numba's threads do not oversubscribe them; or any running Dask
scheduler, given by address (a SLURM or Kubernetes cluster; see the README). One bad file never
stops the batch: its error goes into the summary. A task whose worker dies is retried once on
another worker, then reported (on someone else's scheduler, as often as its
``distributed.scheduler.allowed-failures`` says). Outputs are written atomically, so an output that exists is
complete, and a rerun skips it (``force`` redoes it); a rerun also leaves alone a file that could
not be used (an ``InputError``) and has not changed since, and tries again everything else.
"""

import contextlib
import csv
import errno
import glob
import json
import logging
import multiprocessing
import os
import resource
import shutil
import sys
import tempfile
import time
from dataclasses import fields
from multiprocessing import resource_tracker

from skelfilter.errors import InputError, ResourceError, SkelfilterError
from skelfilter.io import formats, output_files
from skelfilter.jobs import batch_files, denoise_file
from skelfilter.parameter_fields import build
from skelfilter.params import DenoiseParams, VolumeParams
from skelfilter.runtime.extras import need
from skelfilter.runtime.memory import read_field, return_freed_memory
from skelfilter.runtime.progress import Progress
from skelfilter.runtime.signals import deferred, temporary_folder

SUMMARY_FILES = ("summary.csv", "summary.json")
SUMMARY_FIELDS = ("input", "output", "status", "done", "error", "seconds", "peak_memory_mib", "voxels_changed",
                  "bad_input")


def _row(input_path, output_path, status, **values):
    """A summary row: ``values`` over blanks."""
    return {**dict.fromkeys(SUMMARY_FIELDS, ""), "input": input_path, "output": output_path, "status": status,
            **values}


def _task(input_path, output_path, params, volume_params, numba_threads):
    """One file, on a worker: the summary row (never raises for a bad file)."""
    import numba

    if numba_threads is None:  # a worker of someone else's cluster: the cores its threads leave
        get_worker = need("distributed", "a batch on Dask").get_worker

        numba_threads = usable_cores() // max(1, get_worker().state.nthreads)
    numba.set_num_threads(max(1, min(numba_threads, numba.config.NUMBA_NUM_THREADS)))
    return_freed_memory()  # a setting of the worker process, which this task runs in
    _reset_peak_memory()
    start = time.perf_counter()
    row = _row(input_path, output_path, "ok")
    progress = Progress(enabled=False, shield=True)
    try:
        # --label, --iso and --spacing are for the volumes of a mixed batch, the mesh output's and
        # normal filter's choices for its meshes.
        volume = None
        if formats.input_kind(input_path) == "volume":
            volume = volume_params
            params = params.with_(output_mesh=DenoiseParams(preset=params.preset).output_mesh,
                                  normal_filter=DenoiseParams().normal_filter)
        summary = denoise_file.denoise_file(input_path, output_path, params, volume, progress=progress)
        changed = summary["voxels_changed"]
        row.update(voxels_changed="" if changed is None else changed,
                   done="; ".join(progress.notes + ([] if changed is None else [f"voxel stage: {changed} voxels "
                                                                                "changed"])))
    except Exception as exc:  # a bug or a library's failure on one file must not stop the batch either
        row.update(status="failed", **_failure(exc, input_path))
    row["seconds"] = round(time.perf_counter() - start, 3)
    row["peak_memory_mib"] = _peak_memory_mib()
    return row


def _failure(exc, input_path):
    """The summary's ``error`` and ``bad_input`` of a file whose task raised ``exc``."""
    if not os.path.exists(input_path):  # removed or renamed since the batch found it
        return {"error": f"{input_path}: no longer exists", "bad_input": ""}
    if isinstance(exc, InputError):  # the file itself: a rerun leaves it alone while it stays the same
        return {"error": str(exc), "bad_input": _stamp(input_path)}
    if isinstance(exc, (SkelfilterError, MemoryError)):
        return {"error": str(exc) or "out of memory", "bad_input": ""}
    return {"error": f"{type(exc).__name__}: {exc}", "bad_input": ""}


def _reset_peak_memory():
    """Restart the process' peak resident memory count (Linux: ``clear_refs`` 5), so that it
    measures this task alone: a worker runs one task at a time. Elsewhere the count is the
    process' since it started."""
    with contextlib.suppress(OSError), open("/proc/self/clear_refs", "w") as f:
        f.write("5")


def _peak_memory_mib():
    peak = read_field("/proc/self/status", "VmHWM")  # kB
    if peak is not None:
        return round(int(peak) / 1024, 1)
    return round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)


def local_cluster(workers=None, directory=None):
    """A ``LocalCluster`` of ``workers`` single-threaded processes (default: one per core), each
    with numba on ``cores // workers`` threads; a task whose worker dies is retried once. The
    workers keep their scratch files in ``directory`` (default: Dask's, in the temporary folder) and
    serve no dashboard.

    Returns
    -------
    (distributed.Client, int)
        The client, and numba's threads per worker.
    """
    dask = need("dask", "a batch on Dask")
    distributed = need("distributed", "a batch on Dask")
    Client, LocalCluster = distributed.Client, distributed.LocalCluster

    cores = usable_cores()
    workers = workers or cores
    threads = max(1, cores // workers)
    env = {"NUMBA_NUM_THREADS": str(threads), "OMP_NUM_THREADS": str(threads)}
    # One task at a time on a worker (saturation 1), so that a worker's death is blamed on its task
    # alone, which is retried once (allowed failures 1) and then reported. The scheduler reads
    # both when it starts; the workers' log lines (a worker restarted, a task given up) stay out
    # of the terminal, the summary says what they mean.
    settings = {"distributed.scheduler.allowed-failures": 1, "distributed.scheduler.worker-saturation": 1.0,
                "logging.distributed": "critical"}
    if directory is not None:  # the scheduler's scratch files too
        settings["temporary-directory"] = directory
    with dask.config.set(settings):
        # No dashboard; the scheduler's own HTTP routes on a free local port (8787 may be taken).
        try:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                                   scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                                   env=env, local_directory=directory, silence_logs=logging.CRITICAL)
        except (OSError, RuntimeError) as exc:  # distributed reports a worker that could not start so
            raise ResourceError(f"the local Dask cluster did not start: {_start_failure(exc)}") from None
    return Client(cluster), threads


def _start_failure(exc):
    """Why a cluster did not start, in words: the first system error behind ``exc``, if any."""
    seen = exc
    while seen is not None:
        if isinstance(seen, OSError) and seen.errno == errno.EMFILE:
            soft = resource.getrlimit(resource.RLIMIT_NOFILE)[0]
            return (f"too many open files (this process may open {soft}; each worker needs dozens: raise "
                    "the limit, e.g. ulimit -n 1024)")
        if isinstance(seen, OSError) and seen.strerror:
            return seen.strerror.lower()
        seen = seen.__cause__ or seen.__context__
    return str(exc) or type(exc).__name__


def usable_cores():
    """The cores this process may run on (its CPU affinity: a SLURM job's or a container's share)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def quiet_distributed():
    """Silence the log lines of Dask's scheduler and nannies in this process (the CLI's choice: its
    summary says what they mean)."""
    need("distributed", "a batch on Dask")  # its import sets its loggers' levels, which this overrides

    for name in ["distributed", *logging.root.manager.loggerDict]:
        if name.startswith("distributed"):
            logging.getLogger(name).setLevel(logging.CRITICAL)


def denoise_many(paths, out_dir, client=None, workers=None, force=False, to=None, report=None, keep_tree=False,
                 **params):
    """Denoise many files on Dask; writes ``summary.csv`` and ``summary.json`` into ``out_dir``.

    Parameters
    ----------
    paths : list of str
        Files, folders (subfolders included) or glob patterns (`batch_files.find_inputs`).
    out_dir : str
        Created if missing; each output has its input's name (suffix ``to`` if given), a folder's
        files their path below it (its subfolders mirrored).
    keep_tree : bool
        Put each output in the subfolder of ``out_dir`` that mirrors its input's folder below the
        folder all inputs share (created as needed), so that files of one name in several folders
        (``scans/*/noisy.obj``) do not collide.
    client : distributed.Client, optional
        A running cluster's client; by default a `local_cluster` of ``workers`` processes, closed
        at the end.
    force : bool
        Redo files whose output exists (by default they are skipped: outputs are written
        atomically, so one that exists is complete; an empty one is redone), and files the last run found unusable and
        that have not changed since (by default their failure is carried over).
    report : callable, optional
        Called with each finished row and the counts so far (the CLI's progress bar).
    **params
        `DenoiseParams` fields, and `VolumeParams` fields (``label``, ``iso``, ``spacing``).

    Returns
    -------
    list of dict
        One row per input, in input order: ``SUMMARY_FIELDS``; ``status`` is ``ok``, ``skipped`` or
        ``failed`` (with the error's one line); ``done`` says what was done to the file (the routing's
        notes: as it was, smoothed by the fine pass, the voxel stage's voxels changed);
        ``voxels_changed`` is blank where the voxel stage did not run.
    """
    volume_names = {f.name for f in fields(VolumeParams)}
    volume_params = VolumeParams(**{k: v for k, v in params.items() if k in volume_names})
    denoise_params = build(DenoiseParams, None, **{k: v for k, v in params.items() if k not in volume_names})
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise InputError(f"{out_dir}: exists and is not a folder")
    found = batch_files.find_inputs(paths)
    inputs = [path for path, _ in found]
    outputs = batch_files.output_paths(found, out_dir, to, keep_tree)
    created = batch_files.make_folders([out_dir, *(os.path.dirname(out) for out in outputs)])
    try:
        batch_files.check_outputs(inputs, outputs)
        for name in SUMMARY_FILES:  # checked before anything runs, as every output
            output_files.check_output(os.path.join(out_dir, name), inputs)
    except BaseException:
        batch_files.remove_empty(created)
        raise
    rows = {}
    todo = []
    before = {} if force else _previous_bad_inputs(out_dir)
    for path, out in zip(inputs, outputs):
        if force:
            todo.append((path, out))
        elif _done(out):
            rows[path] = _row(path, out, "skipped", done="its output is there", seconds=0.0)
        elif path in before and before[path]["bad_input"] == _stamp(path):
            rows[path] = {**_row(path, out, "failed"), **before[path], "seconds": 0.0, "peak_memory_mib": "",
                          "voxels_changed": ""}
        else:
            todo.append((path, out))
    try:
        if todo:
            rows.update(_run(todo, client, workers, denoise_params, volume_params, report, len(rows)))
    except BaseException:  # interrupted: the finished outputs stay (complete: a rerun skips them)
        batch_files.remove_empty(created)
        raise
    ordered = [rows[path] for path in inputs]
    _write_summary(out_dir, ordered)
    return ordered


def _done(output_path):
    """Whether an output is there (written atomically, a file that is there is complete; an empty one
    is a copy or a write by something else cut short)."""
    return os.path.isfile(output_path) and os.path.getsize(output_path) > 0


def _stamp(path):
    """Size and modification time of a file: whether it changed since a run."""
    stat = os.stat(path)
    return f"{stat.st_size}:{stat.st_mtime_ns}"


def _previous_bad_inputs(out_dir):
    """The rows of the last summary in ``out_dir`` whose input could not be used (by input path)."""
    try:
        with open(os.path.join(out_dir, "summary.json"), encoding="utf-8") as f:
            rows = json.load(f)
        return {row["input"]: row for row in rows if row.get("status") == "failed" and row.get("bad_input")}
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return {}


def _run(todo, client, workers, params, volume_params, report, skipped):
    with contextlib.ExitStack() as stack:
        threads = None
        if client is None:
            client, threads = _own_cluster(stack, workers)
        return _collect(client, todo, threads, params, volume_params, report, skipped)


def _own_cluster(stack, workers):
    """A `local_cluster` that ``stack`` closes, its scratch files in a folder of this run that goes
    with it (and that a later run removes, should this process be killed). Started and closed with
    the signals held: its processes inherit them held, so that a Ctrl-C to the terminal's process
    group reaches this process alone, which closes the cluster."""
    _remove_abandoned_scratch()
    scratch = stack.enter_context(temporary_folder(f"{SCRATCH_PREFIX}{os.getpid()}-"))
    earlier = set(multiprocessing.active_children())
    with deferred():  # multiprocessing's resource tracker unblocks the signals in the thread that starts it
        resource_tracker.ensure_running()
    with deferred():
        client, threads = local_cluster(workers, scratch)
    stack.callback(_close, client, earlier)
    return client, threads


def _close(client, earlier):
    """Close the cluster; then kill any of its worker processes still running (busy in a task past
    Dask's timeouts), so that none outlives the run or writes after it."""
    with deferred():
        cluster = client.cluster
        client.close()
        cluster.close()
        for process in set(multiprocessing.active_children()) - earlier:
            process.kill()
            process.join(10)


SCRATCH_PREFIX = "skelfilter-dask-"


def _remove_abandoned_scratch():
    """Scratch folders of runs whose process is gone (killed outright: nothing could clean up)."""
    for folder in glob.glob(os.path.join(tempfile.gettempdir(), SCRATCH_PREFIX + "*-*")):
        pid = os.path.basename(folder)[len(SCRATCH_PREFIX):].split("-")[0]
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(folder, ignore_errors=True)


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # someone else's process
        return True
    return True


def _collect(client, todo, threads, params, volume_params, report, skipped):
    as_completed = need("distributed", "a batch on Dask").as_completed

    rows, counts = {}, {"done": skipped, "failed": 0, "total": skipped + len(todo)}
    futures = {client.submit(_task, path, out, params, volume_params, threads, pure=False,
                             key=f"skelfilter-{i}-{_printable(os.path.basename(path))}"): (path, out)
               for i, (path, out) in enumerate(todo)}
    for future in as_completed(futures):
        path, out = futures[future]
        try:
            row = future.result()
        except Exception as exc:  # the worker died twice (KilledWorker) or the task could not run
            row = _row(path, out, "failed", error=_worker_error(exc))
        rows[path] = row
        counts["done"] += 1
        counts["failed"] += row["status"] == "failed"
        if report:
            report(row, counts)
    return rows


def _printable(name):
    """A file name as text the scheduler can send (a name that is no UTF-8 broke its connection)."""
    return os.fsencode(name).decode("utf-8", "replace")


def _worker_error(exc):
    if type(exc).__name__ == "KilledWorker":
        return "its worker died, and again on a second try (out of memory? a crash?)"
    return f"{type(exc).__name__}: {exc}"


def _write_summary(out_dir, rows):
    def write_csv(tmp):
        # a name that is no UTF-8 (its bytes kept by Python as surrogates) is written as its bytes
        with open(tmp, "w", newline="", encoding="utf-8", errors="surrogateescape") as f:
            writer = csv.DictWriter(f, fieldnames=SUMMARY_FIELDS)
            writer.writeheader()
            writer.writerows(rows)

    def write_json(tmp):
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(rows, f, indent=1)

    for name, write in zip(SUMMARY_FILES, (write_csv, write_json)):
        output_files.atomic_write(os.path.join(out_dir, name), write)


def progress_bar(stream=None, width=30):
    """A `denoise_many` ``report`` that draws a bar on a terminal, else prints a line per file, on
    ``stream`` (the standard error as it is when called; nothing where it is closed)."""
    stream = stream if stream is not None else sys.stderr
    if stream is None:
        return None
    terminal = stream.isatty()

    def report(row, counts):
        done, total = counts["done"], counts["total"]
        bar = "#" * round(width * done / total) + "-" * (width - round(width * done / total))
        line = (f"[{bar}] {done}/{total}, {counts['failed']} failed: {os.path.basename(row['input'])} "
                f"{row['status']}")
        if terminal:
            stream.write("\r" + line[:200].ljust(120) + ("\n" if done == total else ""))
        else:
            detail = row["error"] or row.get("done")  # why it failed, or what was done to it
            stream.write(line + (f" ({detail})" if detail else "") + "\n")
        stream.flush()

    return report

