"""Command line: ``skelfilter denoise``, ``noise``, ``run-script``, ``export-script``, ``filters`` and
``compare``.

The flags of a filter are generated from its MeshLab-style description (:mod:`skelfilter.meshlab.descriptions`),
itself read off the parameter dataclasses in :mod:`skelfilter.params`.
"""

import argparse
import dataclasses
import logging
import math
import os
import re
import sys
import warnings

from skelfilter.errors import InputError, SkelfilterError
from skelfilter.io import mesh_files, output_files
from skelfilter.jobs import denoise_file
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.meshlab import descriptions, pymeshlab_filters, scripts
from skelfilter.meshlab.descriptions import ADD_SKELETON_NOISE, SKELETON_SALIENCY_DENOISE
from skelfilter.params import DenoiseParams, NoiseParams, VolumeParams
from skelfilter.runtime import memory, signals, worker_threads
from skelfilter.runtime.extras import need
from skelfilter.runtime.progress import Progress


class _Parser(argparse.ArgumentParser):
    """Usage mistakes end like every other refusal: one line ``skelfilter: error: …``, exit 2."""

    def error(self, message):
        self.exit(2, f"skelfilter: error: {message} (see {self.prog} --help)\n")


def _seconds(text):
    """A time limit in seconds: a finite number in (0, 1e6]."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (math.isfinite(value) and 0 < value <= 1e6):
        raise argparse.ArgumentTypeError(f"must be a number of seconds in (0, 1e6], got {text}")
    return value


def _count(text):
    """A number of workers: an integer in [1, 1024]."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if not 1 <= value <= 1024:
        raise argparse.ArgumentTypeError(f"must be an integer in [1, 1024], got {text}")
    return value


def _flag(name):
    return "--" + name.replace("_", "-")


def _add_filter_flags(parser, description, full_help=True):
    """The filter's parameters as flags. Where some parameters have a summary (the few most users
    set) and ``full_help`` is off, those are shown in their plain words and the others hidden from
    ``--help`` (they still work; ``--help-all`` shows them)."""
    short = not full_help and any(p.summary for p in description.parameters)
    advanced = parser if not short and not any(p.summary for p in description.parameters) else \
        parser.add_argument_group("advanced parameters (the thesis' method, §8.1; `skelfilter filters` "
                                  "describes them too)")
    for p in description.parameters:
        if short:
            help_text = p.summary or argparse.SUPPRESS
        else:
            help_text = p.full_tooltip + (f" (default: {p.default})" if p.default is not None else "")
        group = parser if p.summary else advanced
        if p.value_type is bool:
            group.add_argument(_flag(p.name), dest=p.name, action=argparse.BooleanOptionalAction,
                               default=None, help=help_text)
            continue
        group.add_argument(
            _flag(p.name),
            dest=p.name,
            type=p.value_type,
            default=None,
            choices=p.choices or None,
            metavar=None if p.choices else p.name.upper(),
            help=help_text,
        )
    if any(p.summary for p in description.parameters):
        parser.add_argument("--help-all", action="store_true",
                            help="show this help with every parameter, in the thesis' terms, and exit")


def _params(description, args):
    given = {p.name: getattr(args, p.name) for p in description.parameters
             if getattr(args, p.name) is not None}
    return description.params_class(**given)


def build_parser(full_help=False):
    """The CLI's parser; ``full_help``: ``--help`` lists every parameter (what ``--help-all`` asks)."""
    parser = _Parser(
        prog="skelfilter",
        description="Remove small-scale bumps and dents from meshes by pruning the surface skeleton.",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    den = sub.add_parser("denoise", help="denoise a mesh (thesis §8.1.1)")
    den.add_argument("input", help="input mesh (PLY, OBJ, STL, OFF, GLB), volume (NIfTI .nii/.nii.gz, "
                     "NRRD, TIFF stack, .npy) or point cloud (PCD, XYZ, XYZN, PTS, PLY without faces); never "
                     "modified")
    den.add_argument("output", help="output mesh, or for a volume input a volume (the input's grid, header "
                     "and affine) or a mesh in the scanner's world coordinates; written atomically")
    _add_filter_flags(den, SKELETON_SALIENCY_DENOISE, full_help)
    den.add_argument("--close", action="store_true", help="write a new watertight mesh of the denoised "
                     "solid (marching cubes), the same as --output-mesh closed")
    den.add_argument("--points", action="store_true", help="for a point cloud input: write its points moved "
                     "onto the denoised surface, with their attributes (PLY, PCD, XYZ), not the mesh")
    den.add_argument("--save-skeleton", metavar="FILE", help=argparse.SUPPRESS if not full_help else
                     "write the skeleton voxels as a PLY point cloud with per-point D, rho, sigma_bar, "
                     "rho_plus (quality = rho_plus)")
    _add_volume_flags(den)
    _add_display_flags(den)

    noi = sub.add_parser("noise", help="add the thesis' synthetic noise (§7.2) to a mesh")
    noi.add_argument("input", help="input mesh; never modified")
    noi.add_argument("output", help="noisy output mesh, written atomically")
    _add_filter_flags(noi, ADD_SKELETON_NOISE)
    _add_display_flags(noi)

    bat = sub.add_parser("batch", help="denoise many files on Dask (a local cluster, or a scheduler's)")
    bat.add_argument("inputs", nargs="+", metavar="INPUT", help="files, folders (their mesh, volume and "
                     "point-cloud files) or glob patterns; each file is one task")
    bat.add_argument("--out", required=True, metavar="DIR", help="output folder: each result has its input's "
                     "name, plus summary.csv and summary.json")
    bat.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler (tcp://host:8786); "
                     "default: a local cluster")
    bat.add_argument("--workers", type=_count, metavar="N", help="local worker processes (default: one per "
                     "core); numba's threads share the rest of the cores")
    bat.add_argument("--to", metavar="EXT", help="output format, e.g. ply for meshes of volumes (default: "
                     "the input's)")
    bat.add_argument("--force", action="store_true", help="redo files whose output exists (default: skip "
                     "them; outputs are written atomically, so one that exists is complete)")
    _add_filter_flags(bat, SKELETON_SALIENCY_DENOISE, full_help)
    _add_volume_flags(bat)
    _add_display_flags(bat)

    run = sub.add_parser("run-script", help="run a MeshLab filter script (.mlx) mixing MeshLab's "
                         "filters and skelfilter's")
    run.add_argument("script", help="the .mlx filter script, checked whole before anything runs")
    run.add_argument("input", help="input mesh (layer 0); never modified")
    run.add_argument("output", help="the current layer at the end, written atomically")
    run.add_argument("--timeout", type=_seconds, default=300.0, metavar="SECONDS",
                     help="time each run of consecutive MeshLab filters may take (default: 300)")
    _add_display_flags(run)

    exp = sub.add_parser("export-script", help="write a MeshLab filter script (.mlx) applying a "
                         "skelfilter filter with the given parameters")
    which = exp.add_subparsers(dest="filter", required=True, metavar="{" + ",".join(
        d.command for d in descriptions.FILTERS) + "}")
    for description in descriptions.FILTERS:
        one = which.add_parser(description.command, help=f"a script applying {description.name!r}")
        one.add_argument("output", help="the .mlx script, written atomically")
        _add_filter_flags(one, description)

    lst = sub.add_parser("filters", help="list skelfilter's filters (and MeshLab's) with their parameters")
    lst.add_argument("name", nargs="?", help="show only this filter (skelfilter's, or pymeshlab's name)")
    lst.add_argument("--meshlab", action="store_true", help="also list MeshLab's filters, as pymeshlab "
                     "names them and their parameters")
    lst.add_argument("--markdown", action="store_true", help="print docs/filters.md")

    cmp = sub.add_parser("compare", help="run skelfilter and MeshLab's filters on the same noisy meshes "
                         "and write a report (thesis §8.2)")
    cmp.add_argument("config", nargs="?", help="TOML configuration (default: the thesis' protocol, "
                     "skelfilter/evaluation/comparison/default.toml)")
    cmp.add_argument("--out", default="comparison-output", help="output folder (default: comparison-output)")
    cmp.add_argument("--jobs", type=int, help="MeshLab/MeshLib child processes at once (overrides [run] jobs)")
    cmp.add_argument("--resolution", type=int, help="noise grid resolution (overrides [run] resolution)")
    _add_display_flags(cmp)
    return parser


def _add_volume_flags(parser):
    group = parser.add_argument_group("volume input")
    described = {f.name: f.metadata for f in dataclasses.fields(VolumeParams)}
    choice = group.add_mutually_exclusive_group()
    choice.add_argument("--label", type=int, metavar="N", help=described["label"]["help"])
    choice.add_argument("--iso", type=float, metavar="LEVEL", help=described["iso"]["help"])
    group.add_argument("--spacing", type=float, nargs=3, metavar=("X", "Y", "Z"), help=described["spacing"]["help"])


def _add_display_flags(parser):
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--progress", dest="progress", action="store_true", default=None,
                       help="show step progress (default: only on a terminal)")
    group.add_argument("--quiet", dest="progress", action="store_false", help="print nothing but errors")


def _denoise(args):
    if args.close:
        if args.output_mesh not in (None, "closed"):
            raise InputError(f"--close contradicts --output-mesh {args.output_mesh}")
        args.output_mesh = "closed"
    params = _params(SKELETON_SALIENCY_DENOISE, args)
    volume = VolumeParams(label=args.label, iso=args.iso, spacing=args.spacing)
    progress = Progress(enabled=args.progress, shield=True)
    summary = denoise_file.denoise_file(args.input, args.output, params, volume, args.save_skeleton, progress,
                                 points=args.points)
    if args.progress is None and not progress.enabled:
        for line in progress.notes:
            print(f"skelfilter: {line}", file=sys.stderr)
    if progress.enabled:
        total = sum(progress.timings.values())
        shape = (f"{summary['vertices']} vertices, {summary['faces']} faces" if "faces" in summary
                 else f"{summary['voxels_changed']} voxels changed")
        print(f"wrote {args.output}: {shape} ({total:.1f} s)", file=sys.stderr)


def _batch(args):
    from skelfilter.jobs import batch

    batch.quiet_distributed()

    params = {p.name: getattr(args, p.name) for p in SKELETON_SALIENCY_DENOISE.parameters
              if getattr(args, p.name) is not None}
    params.update({k: getattr(args, k) for k in ("label", "iso", "spacing") if getattr(args, k) is not None})
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
                                  **params)
    finally:
        if client is not None:
            client.close()
    counts = {status: sum(r["status"] == status for r in rows) for status in ("ok", "skipped", "failed")}
    if args.progress is not False:
        print(f"skelfilter: {counts['ok']} denoised, {counts['skipped']} skipped (output there), "
              f"{counts['failed']} failed; see {os.path.join(args.out, 'summary.csv')}", file=sys.stderr)
    return 1 if counts["failed"] else 0


def _noise(args):
    params = _params(ADD_SKELETON_NOISE, args)
    output_files.check_output(args.output, [args.input], mesh_files.MESH_FORMATS)
    mesh = mesh_files.load_mesh(args.input)
    mesh_files.check_mesh_output(mesh, args.output)
    progress = Progress(enabled=args.progress, shield=True)
    noisy, _, _ = mesh_pipeline.noisy_mesh(mesh, params, progress)
    mesh_files.save_mesh(noisy, args.output, protect=[args.input])


def _run_script(args):
    steps = scripts.read_script(args.script)
    output_files.check_output(args.output, {args.input: "input", args.script: "script"}, mesh_files.MESH_FORMATS)
    mesh = mesh_files.load_mesh(args.input)
    progress = Progress(enabled=args.progress, shield=True)
    layers = scripts.run_steps(steps, mesh, args.timeout, progress)
    out = mesh_files.validate_mesh(layers.current_mesh, f"{args.script}: the current layer at the end")
    mesh_files.save_mesh(out, args.output, protect={args.input: "input", args.script: "script"})
    if args.progress is not False:  # what it wrote, unless --quiet
        print(f"wrote {args.output}: layer {layers.current} of {len(layers.meshes)}, "
              f"{len(out.vertices)} vertices, {len(out.faces)} faces", file=sys.stderr)


def _export_script(args):
    description = descriptions.find(args.filter)
    scripts.export_script(args.output, description, _params(description, args))


def _meshlab_filter_text(name, params):
    lines = [f"{name} (pymeshlab)"]
    lines += [f"  {p}: {kind} = {default}" for p, (kind, default) in params.items()]
    return "\n".join(lines)


def _filters(args):
    if args.markdown:
        print(descriptions.markdown(), end="")
        return
    if args.name:
        description = descriptions.find(args.name)
        if description is not None:
            print(descriptions.text(description))
            return
        pname = pymeshlab_filters.python_filter_name(args.name) or args.name
        params = pymeshlab_filters.parameter_lists().get(pname)
        if params is None:
            raise InputError(f"no filter {args.name!r}: not a skelfilter filter "
                             f"({', '.join(d.name for d in descriptions.FILTERS)}) nor a pymeshlab filter")
        print(_meshlab_filter_text(pname, params))
        return
    print("\n\n".join(descriptions.text(d) for d in descriptions.FILTERS))
    if args.meshlab:
        for name, params in sorted(pymeshlab_filters.parameter_lists().items()):
            print("\n" + _meshlab_filter_text(name, params))


def _compare(args):
    from skelfilter.runtime.extras import COMPARE_MODULES

    for module in COMPARE_MODULES:
        need(module, "skelfilter compare", extra="compare")
    from skelfilter.evaluation.comparison.config import load_config
    from skelfilter.evaluation.comparison.run import Reporter, run_compare

    if args.config is not None and not os.path.isfile(args.config):
        raise InputError(f"{args.config}: no such configuration file")
    if not args.out:
        raise InputError("--out: the output folder's name is empty")
    if os.path.exists(args.out) and not os.path.isdir(args.out):
        raise InputError(f"{args.out}: exists and is not a folder")
    config = load_config(args.config, jobs=args.jobs, resolution=args.resolution)
    run_compare(config, args.out, Reporter(enabled=args.progress is not False))


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
            signals.unblock()
            argv, full_help = _help_all(sys.argv[1:] if argv is None else list(argv))
            args = build_parser(full_help).parse_args(argv)
            _route_library_messages(getattr(args, "progress", None) is False)
            memory.return_freed_memory()
            if args.command != "denoise":  # denoise starts them only once it has something to do
                worker_threads.start()
            return COMMANDS[args.command](args) or 0
        finally:
            signals.block()  # from here to the exit a signal waits, and goes with the process
            signals.ignore_from_now()
    except BaseException as exc:  # noqa: BLE001 - each kind gets its line below; the rest is re-raised
        return _exit_status(exc)


def _help_all(argv):
    """``argv`` with ``--help-all`` (before any ``--``) made ``--help``, and whether it was there."""
    end = argv.index("--") if "--" in argv else len(argv)
    if "--help-all" not in argv[:end]:
        return argv, False
    return [("--help" if a == "--help-all" and i < end else a) for i, a in enumerate(argv)], True


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
