"""The command line's parser: one sub-command per job, the filters' parameters as flags (from the
parameter table, `skelfilter.meshlab.descriptions`), usage mistakes as one line."""

import argparse
import dataclasses
import math

from skelfilter.meshlab import descriptions
from skelfilter.meshlab.descriptions import ADD_SKELETON_NOISE, SKELETON_SALIENCY_DENOISE
from skelfilter.params import VolumeParams


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
    if short:
        parser.add_argument("--help-all", action="store_true",
                            help="show every parameter, in the thesis' terms, and exit")


def build_parser(full_help=False):
    """The CLI's parser; ``full_help``: ``--help`` lists every parameter (what ``--help-all`` asks)."""
    parser = _Parser(
        prog="skelfilter",
        description="Remove small-scale bumps and dents from meshes by pruning the surface skeleton.",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    den = sub.add_parser("denoise", help="denoise a mesh (thesis §8.1.1)")
    den.add_argument("input", help="input mesh (PLY, OBJ, STL, OFF, GLB), volume (NIfTI .nii/.nii.gz, "
                     "NRRD, TIFF stack, VTK image data .vti, .npy) or point cloud (PCD, XYZ, XYZN, PTS, PLY "
                     "without faces); never modified")
    den.add_argument("output", help="output mesh, or for a volume input a volume (the input's grid, header "
                     "and affine) or a mesh in the scanner's world coordinates; written atomically")
    _add_filter_flags(den, SKELETON_SALIENCY_DENOISE, full_help)
    den.add_argument("--close", action="store_true", help="a new watertight mesh: --output-mesh closed")
    den.add_argument("--points", action="store_true", help="for a point cloud: write its points moved onto the "
                     "surface, attributes kept (PLY, PCD, XYZ)")
    den.add_argument("--save-skeleton", metavar="FILE", help="also write the skeleton as a PLY point cloud "
                     "with D, rho, sigma_bar, rho_plus per point")
    den.add_argument("--preview", metavar="PNG", help="also write a picture of the input and the output side "
                     "by side (a PNG; matplotlib draws every face, so a mesh of millions takes a while)")
    _add_volume_flags(den)
    _add_display_flags(den)

    noi = sub.add_parser("noise", help="add the thesis' synthetic noise (§7.2) to a mesh")
    noi.add_argument("input", help="input mesh; never modified")
    noi.add_argument("output", help="noisy output mesh, written atomically")
    _add_filter_flags(noi, ADD_SKELETON_NOISE)
    _add_display_flags(noi)

    bat = sub.add_parser("batch", help="denoise many files on Dask (a local cluster, or a scheduler's)")
    bat.add_argument("inputs", nargs="+", metavar="INPUT", help="files, folders (subfolders included) or glob "
                     "patterns (** reaches every depth); each file is one task")
    bat.add_argument("--out", required=True, metavar="DIR", help="output folder: the results, and "
                     "summary.csv/.json saying what was done to each file")
    bat.add_argument("--scheduler", metavar="ADDRESS", help="a running Dask scheduler (tcp://host:8786); "
                     "default: a local cluster")
    bat.add_argument("--workers", type=_count, metavar="N", help="local worker processes (default: one per "
                     "core); numba's threads share the rest of the cores")
    bat.add_argument("--to", metavar="EXT", help="output format, e.g. ply for meshes of volumes (default: "
                     "the input's)")
    bat.add_argument("--keep-tree", action="store_true", help="mirror the inputs' folders under --out: "
                     "scans/*/noisy.obj gives out/<each folder>/noisy.obj")
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
                         "and write a report with pictures and tables (thesis §8.2)")
    cmp.add_argument("inputs", nargs="*", metavar="MESH|CONFIG",
                     help="noisy meshes or folders of them (each as it is: skelfilter's default beside "
                     "MeshLab's Laplacian, Two-step, MLS and RIMLS), or one TOML configuration for full "
                     "control; none: the thesis' protocol (skelfilter/evaluation/comparison/default.toml)")
    cmp.add_argument("--clean", metavar="REF", help="the clean mesh of the one noisy mesh given: the full "
                     "metrics against it (without it: roughness, distance moved, volume change)")
    cmp.add_argument("--out", default="comparison-output", help="output folder (default: comparison-output)")
    cmp.add_argument("--jobs", type=int, help="MeshLab/MeshLib child processes at once (overrides [run] jobs)")
    cmp.add_argument("--resolution", type=int, help="voxels along the longest side of the grid the distances "
                     "are measured in (160; a configuration's noise grid too: overrides [run] resolution)")
    _add_display_flags(cmp)
    return parser


def _add_volume_flags(parser):
    group = parser.add_argument_group("volume input")
    described = {f.name: f.metadata for f in dataclasses.fields(VolumeParams)}
    choice = group.add_mutually_exclusive_group()
    choice.add_argument("--label", type=int, metavar="N", help=described["label"]["help"])
    choice.add_argument("--all-labels", action="store_true", default=None, help=described["all_labels"]["help"])
    choice.add_argument("--iso", type=float, metavar="LEVEL", help=described["iso"]["help"])
    group.add_argument("--spacing", type=float, nargs=3, metavar=("X", "Y", "Z"), help=described["spacing"]["help"])


def _add_display_flags(parser):
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--progress", dest="progress", action="store_true", default=None,
                       help="show step progress (default: only on a terminal)")
    group.add_argument("--quiet", dest="progress", action="store_false", help="print nothing but errors")


def help_all(argv):
    """``argv`` with ``--help-all`` (before any ``--``) made ``--help``, and whether it was there."""
    end = argv.index("--") if "--" in argv else len(argv)
    if "--help-all" not in argv[:end]:
        return argv, False
    return [("--help" if a == "--help-all" and i < end else a) for i, a in enumerate(argv)], True
