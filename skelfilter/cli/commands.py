"""Command line: ``skelfilter denoise``, ``noise``, ``run-script``, ``export-script``, ``filters`` and
``compare``.

The flags of a filter are generated from its MeshLab-style description (:mod:`skelfilter.meshlab.descriptions`),
itself read off the parameter dataclasses in :mod:`skelfilter.params`.
"""

import dataclasses
import functools
import importlib
import logging
import os
import re
import sys
import warnings

from skelfilter.cli import parser
from skelfilter.errors import InputError, ParameterError, SkelfilterError
from skelfilter.meshlab import descriptions
from skelfilter.meshlab.descriptions import ADD_SKELETON_NOISE, SKELETON_SALIENCY_DENOISE
from skelfilter.params import DenoiseParams, NoiseParams, VolumeParams
from skelfilter.runtime import memory, signals
from skelfilter.runtime.extras import need
from skelfilter.runtime.progress import Progress

# What the commands run on: trimesh, numba's kernels, scipy. Loaded once the command line is read
# (`run`), not with this module, so that `--help` and a mistyped flag answer in a tenth of a second.
LIBRARIES = ("skelfilter.io.formats", "skelfilter.io.mesh_files", "skelfilter.io.output_files",
             "skelfilter.jobs.denoise_file", "skelfilter.mesh.pipeline", "skelfilter.meshlab.filter_catalogue",
             "skelfilter.meshlab.scripts", "skelfilter.runtime.worker_threads")


def _params(description, args):
    given = {p.name: getattr(args, p.name) for p in description.parameters
             if getattr(args, p.name) is not None}
    return description.params_class(**given)


def _denoise(args):
    from skelfilter.io import output_files
    from skelfilter.jobs import denoise_file

    if args.close:
        if args.output_mesh not in (None, "closed"):
            raise InputError(f"--close contradicts --output-mesh {args.output_mesh}")
        args.output_mesh = "closed"
    params = _params(SKELETON_SALIENCY_DENOISE, args)
    volume = VolumeParams(label=args.label, iso=args.iso, spacing=args.spacing, all_labels=bool(args.all_labels))
    progress = Progress(enabled=args.progress, shield=True)
    preview = None
    if args.preview:
        protect = {args.input: "input", args.output: "output"}
        if args.save_skeleton:
            protect[args.save_skeleton] = "skeleton"
        output_files.check_output(args.preview, protect, ("png",))
        preview = functools.partial(_write_preview, args.preview, protect, progress, args.input)
    summary = denoise_file.denoise_file(args.input, args.output, params, volume, args.save_skeleton, progress,
                                 points=args.points, preview=preview)
    if args.progress is None and not progress.enabled:
        for line in progress.notes:
            print(f"skelfilter: {line}", file=sys.stderr)
    if progress.enabled:
        total = sum(progress.timings.values())
        shape = (f"{summary['vertices']} vertices, {summary['faces']} faces" if "faces" in summary
                 else f"{summary['voxels_changed']} voxels changed")
        print(f"wrote {args.output}: {shape} ({total:.1f} s)", file=sys.stderr)


def _write_preview(path, protect, progress, source, before, after):
    """``--preview``: the input and the output side by side, from the camera ``skelfilter compare``
    chooses for the input (``source``: the input's path, whose format says which axis is up)."""
    from skelfilter.evaluation import camera, figures
    from skelfilter.io import output_files

    with progress.step("preview"):
        output_files.atomic_write(path, lambda tmp: figures.save_panels(
            [before, after], ["input", "denoised"], tmp, up=camera.up_for(source)), protect=protect)


def _batch(args):
    from skelfilter.jobs import batch

    batch.quiet_distributed()

    params = {p.name: getattr(args, p.name) for p in SKELETON_SALIENCY_DENOISE.parameters
              if getattr(args, p.name) is not None}
    params.update({k: getattr(args, k) for k in ("label", "all_labels", "iso", "spacing")
                   if getattr(args, k) is not None})
    client = None
    if args.scheduler:
        Client = need("distributed", "--scheduler").Client

        try:
            client = Client(args.scheduler, timeout="20s")
        except (OSError, ValueError, TypeError) as exc:  # refused, timed out, or not an address at all
            raise InputError(f"--scheduler {args.scheduler}: cannot connect ({str(exc) or type(exc).__name__})") \
                from None
    try:
        rows = batch.denoise_many(args.inputs, args.out, client=client, workers=args.workers, force=args.force,
                                  to=args.to, report=batch.progress_bar() if args.progress is not False else None,
                                  keep_tree=args.keep_tree, **params)
    finally:
        if client is not None:
            client.close()
    counts = {status: sum(r["status"] == status for r in rows) for status in ("ok", "skipped", "failed")}
    if args.progress is not False:
        print(f"skelfilter: {counts['ok']} denoised, {counts['skipped']} skipped (output there), "
              f"{counts['failed']} failed; see {os.path.join(args.out, 'summary.csv')}", file=sys.stderr)
    failed = [r for r in rows if r["status"] == "failed"]
    if failed:  # said under --quiet too: the exit status alone does not say which file
        first = failed[0]["error"] if failed[0]["error"].startswith(failed[0]["input"]) else \
            f"{failed[0]['input']}: {failed[0]['error']}"
        print(f"skelfilter: error: {len(failed)} of {len(rows)} files failed, the first {first}; see "
              f"{os.path.join(args.out, 'summary.csv')}", file=sys.stderr)
    return 1 if failed else 0


def _noise(args):
    from skelfilter.io import formats, mesh_files, output_files
    from skelfilter.mesh import pipeline as mesh_pipeline

    params = _params(ADD_SKELETON_NOISE, args)
    output_files.check_output(args.output, [args.input], formats.MESH_FORMATS)
    mesh = mesh_files.load_mesh(args.input)
    mesh_files.check_mesh_output(mesh, args.output)
    progress = Progress(enabled=args.progress, shield=True)
    noisy, _, _ = mesh_pipeline.noisy_mesh(mesh, params, progress)
    mesh_files.save_mesh(noisy, args.output, protect=[args.input])


def _run_script(args):
    from skelfilter.io import formats, mesh_files, output_files
    from skelfilter.meshlab import scripts

    steps = scripts.read_script(args.script)
    output_files.check_output(args.output, {args.input: "input", args.script: "script"}, formats.MESH_FORMATS)
    mesh = mesh_files.load_mesh(args.input)
    progress = Progress(enabled=args.progress, shield=True)
    layers = scripts.run_steps(steps, mesh, args.timeout, progress)
    out = mesh_files.validate_mesh(layers.current_mesh, f"{args.script}: the current layer at the end")
    mesh_files.save_mesh(out, args.output, protect={args.input: "input", args.script: "script"})
    if args.progress is not False:  # what it wrote, unless --quiet
        print(f"wrote {args.output}: layer {layers.current} of {len(layers.meshes)}, "
              f"{len(out.vertices)} vertices, {len(out.faces)} faces", file=sys.stderr)


def _export_script(args):
    from skelfilter.meshlab import scripts

    description = descriptions.find(args.filter)
    scripts.export_script(args.output, description, _params(description, args))


def _meshlab_filter_text(name, params):
    lines = [f"{name} (pymeshlab)"]
    lines += [f"  {p}: {kind} = {default}" for p, (kind, default) in params.items()]
    return "\n".join(lines)


def _filters(args):
    from skelfilter.meshlab import filter_catalogue

    if args.markdown:
        print(descriptions.markdown(), end="")
        return
    if args.name:
        description = descriptions.find(args.name)
        if description is not None:
            print(descriptions.text(description))
            return
        pname = filter_catalogue.python_filter_name(args.name) or args.name
        params = filter_catalogue.parameter_lists().get(pname)
        if params is None:
            raise InputError(f"no filter {args.name!r}: not a skelfilter filter "
                             f"({', '.join(d.name for d in descriptions.FILTERS)}) nor a pymeshlab filter")
        print(_meshlab_filter_text(pname, params))
        return
    print("\n\n".join(descriptions.text(d) for d in descriptions.FILTERS))
    if args.meshlab:
        for name, params in sorted(filter_catalogue.parameter_lists().items()):
            print("\n" + _meshlab_filter_text(name, params))


def _compare(args):
    from skelfilter.runtime.extras import COMPARE_MODULES

    for module in COMPARE_MODULES:
        need(module, "skelfilter compare", extra="compare")
    from skelfilter.evaluation.comparison.config import config_for_meshes, load_config
    from skelfilter.evaluation.comparison.run import Reporter, run_compare

    if not args.out:
        raise InputError("--out: the output folder's name is empty")
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise InputError(f"{args.out}: exists and is not a folder")
    overrides = {"jobs": args.jobs, "resolution": args.resolution}
    configs = [p for p in args.inputs if str(p).lower().endswith(".toml")]
    if configs:
        if len(args.inputs) > 1 or args.clean is not None:
            raise ParameterError("compare: a TOML configuration names its own meshes; give it alone")
        if not os.path.isfile(configs[0]):
            raise InputError(f"{configs[0]}: no such configuration file")
        config = load_config(configs[0], **overrides)
    elif args.inputs:
        config = config_for_meshes(_meshes(args.inputs), clean=args.clean, **overrides)
    else:
        if args.clean is not None:
            raise ParameterError("--clean: give the noisy mesh it belongs to")
        config = load_config(None, **overrides)
    run_compare(config, args.out, Reporter(enabled=args.progress is not False))


def _meshes(inputs):
    """The mesh files among ``inputs`` (files, folders, patterns); what else a folder holds is left."""
    from skelfilter.io import formats
    from skelfilter.jobs.batch_files import expand_inputs

    found = expand_inputs(inputs)
    meshes = [p for p in found if formats.input_kind(p) == "mesh"]
    others = sorted(set(found) - set(meshes))
    named = [p for p in others if any(os.path.abspath(str(i)) == p for i in inputs)]
    if named:
        raise InputError(f"{named[0]}: not a mesh; compare takes meshes (volumes and point clouds: "
                         "skelfilter denoise)")
    if not meshes:
        raise InputError("compare: no mesh among the inputs")
    return meshes


# Library messages name parameters backticked (`threshold`); the CLI's names for them are its flags.
_FLAG_NAMES = frozenset(f.name for cls in (DenoiseParams, NoiseParams, VolumeParams)
                        for f in dataclasses.fields(cls)) | {"save_skeleton"}


def _in_cli_terms(message):
    """A library message with each backticked parameter named by its flag (`save_skeleton` -> --save-skeleton)."""
    return re.sub(r"`([a-z_]+)`", lambda m: "--" + m.group(1).replace("_", "-") if m.group(1) in _FLAG_NAMES
                  else m.group(0), message)


class _OneLineFormatter(logging.Formatter):
    """``skelfilter: warning: …`` on one line: no traceback a library attaches to its record."""

    def format(self, record):
        return f"skelfilter: warning: {one_line(' '.join(record.getMessage().split()))}"


def _route_library_messages(quiet):
    """Library warnings and log records become one ``skelfilter: warning: …`` line each, or nothing
    under ``--quiet``."""
    level = logging.CRITICAL + 1 if quiet else logging.WARNING
    logging.basicConfig(level=level, force=True)
    logging.root.handlers[0].setLevel(level)  # also for records of loggers with lower levels of their own
    logging.root.handlers[0].setFormatter(_OneLineFormatter())
    if quiet:
        warnings.simplefilter("ignore")
        return
    warnings.showwarning = lambda message, category, *rest: print(
        f"skelfilter: warning: {one_line(' '.join(str(message).split()))}", file=sys.stderr)


COMMANDS = {"denoise": _denoise, "noise": _noise, "run-script": _run_script, "export-script": _export_script,
            "filters": _filters, "compare": _compare, "batch": _batch}


def one_line(message):
    """``message`` on one line: control characters (a newline in a file name) shown escaped."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in message)


def run(argv=None):
    """Run one command in this process; returns its exit status.

    Called by :func:`skelfilter.cli.main`, which holds the signals and installs the handlers first:
    they are let in here, inside the error handling, and held again as the command ends (with an
    error or not), so that what it reports is one line and nothing interrupts the report.
    """
    try:
        try:
            argv, full_help = parser.help_all(sys.argv[1:] if argv is None else list(argv))
            args = parser.build_parser(full_help).parse_args(argv)
            for name in LIBRARIES:  # their native threads start with the signals held
                importlib.import_module(name)
            signals.unblock()
            _route_library_messages(getattr(args, "progress", None) is False)
            memory.return_freed_memory()
            if args.command != "denoise":  # denoise starts them only once it has something to do
                from skelfilter.runtime import worker_threads

                worker_threads.start()
            return COMMANDS[args.command](args) or 0
        finally:
            signals.block()  # from here to the exit a signal waits, and goes with the process
            signals.ignore_from_now()
    except BaseException as exc:  # noqa: BLE001 - each kind gets its line below; the rest is re-raised
        return _exit_status(exc)


def _interrupt_behind(exc):
    """The `signals.Interrupted` that ``exc`` was raised while handling, if any: a library that turns
    every failure into its own error (VTK's lazy imports give ImportError) still carries it."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, signals.Interrupted):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def _current_folder_gone():
    try:
        os.getcwd()
    except FileNotFoundError:
        return True
    return False


def _exit_status(exc):
    exc = _interrupt_behind(exc) or exc
    if isinstance(exc, SystemExit):
        return exc.code
    if isinstance(exc, BrokenPipeError):  # `skelfilter filters --meshlab | head`: quiet, as Unix tools are
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + 13
    if isinstance(exc, signals.Interrupted):
        message, status = exc.word, exc.exit_status
    elif isinstance(exc, KeyboardInterrupt):
        message, status = "interrupted", 130
    elif isinstance(exc, SkelfilterError):
        message, status = f"error: {_in_cli_terms(str(exc))}", 2
    elif isinstance(exc, FileNotFoundError) and _current_folder_gone():
        message, status = ("error: the current folder no longer exists (it was deleted or moved): run from an "
                           "existing folder, or give absolute paths"), 2
    elif isinstance(exc, OSError):  # what the system refused, where no step said it better
        where = f" ({exc.filename})" if exc.filename else ""
        message, status = f"error: {(exc.strerror or str(exc) or type(exc).__name__).lower()}{where}", 2
    elif isinstance(exc, MemoryError):
        message, status = "error: out of memory (the input is too large for the memory available)", 2
    else:
        raise exc
    print(f"skelfilter: {one_line(message)}", file=sys.stderr)
    return status
