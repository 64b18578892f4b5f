"""Command line: ``skelfilter denoise``, ``skelfilter noise`` and ``skelfilter compare``.

Flags are generated from the parameter dataclasses in :mod:`skelfilter.params`.
"""

import argparse
import sys
import typing
from dataclasses import MISSING, fields

import numpy as np

from . import io, pipeline
from .errors import SkelfilterError
from .params import DenoiseParams, NoiseParams
from .progress import Progress


def _flag(name):
    return "--" + name.replace("_", "-")


def _value_type(f):
    """``int`` for ``int | None`` and the like."""
    args = [a for a in typing.get_args(f.type) if a is not type(None)]
    return args[0] if args else f.type


def _add_dataclass_flags(parser, cls):
    for f in fields(cls):
        meta = f.metadata
        default = f.default if f.default is not MISSING else None
        help_text = meta.get("help", "")
        if meta.get("unit"):
            help_text += f" [{meta['unit']}]"
        if default is not None:
            help_text += f" (default: {default})"
        kind = _value_type(f)
        if kind is bool:
            parser.add_argument(_flag(f.name), dest=f.name, action="store_true", default=None, help=help_text)
            continue
        parser.add_argument(
            _flag(f.name),
            dest=f.name,
            type=kind,
            default=None,
            choices=meta.get("choices"),
            metavar=None if meta.get("choices") else f.name.upper(),
            help=help_text,
        )


def _params(cls, args):
    given = {f.name: getattr(args, f.name) for f in fields(cls) if getattr(args, f.name) is not None}
    return cls(**given)


def build_parser():
    parser = argparse.ArgumentParser(
        prog="skelfilter",
        description="Remove small-scale bumps and dents from meshes by pruning the surface skeleton.",
    )
    sub = parser.add_subparsers(dest="command", required=True)

    den = sub.add_parser("denoise", help="denoise a mesh (thesis §8.1.1)")
    den.add_argument("input", help="input mesh (PLY, OBJ, STL, OFF, GLB); never modified")
    den.add_argument("output", help="output mesh, written atomically")
    _add_dataclass_flags(den, DenoiseParams)
    den.add_argument("--save-skeleton", metavar="FILE", help="write the skeleton voxels as a PLY point "
                     "cloud with per-point D, rho, sigma_bar, rho_plus (quality = rho_plus)")
    _add_display_flags(den)

    noi = sub.add_parser("noise", help="add the thesis' synthetic noise (§7.2) to a mesh")
    noi.add_argument("input", help="input mesh; never modified")
    noi.add_argument("output", help="noisy output mesh, written atomically")
    _add_dataclass_flags(noi, NoiseParams)
    _add_display_flags(noi)

    cmp = sub.add_parser("compare", help="run skelfilter and MeshLab's filters on the same noisy meshes "
                         "and write a report (thesis §8.2)")
    cmp.add_argument("config", nargs="?", help="TOML configuration (default: the thesis' protocol, "
                     "comparisons/default.toml)")
    cmp.add_argument("--out", default="comparison-output", help="output folder (default: comparison-output)")
    cmp.add_argument("--jobs", type=int, help="MeshLab/MeshLib child processes at once (overrides [run] jobs)")
    cmp.add_argument("--resolution", type=int, help="noise grid resolution (overrides [run] resolution)")
    _add_display_flags(cmp)
    return parser


def _add_display_flags(parser):
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--progress", dest="progress", action="store_true", default=None,
                       help="show step progress (default: only on a terminal)")
    group.add_argument("--quiet", dest="progress", action="store_false", help="print nothing but errors")


def _denoise(args):
    params = _params(DenoiseParams, args)
    mesh = io.load_mesh(args.input)
    progress = Progress(enabled=args.progress)
    out, result, grid = pipeline.denoise_mesh_detailed(mesh, params, progress)
    protect = [args.input]
    io.save_mesh(out, args.output, protect=protect)
    if args.save_skeleton:
        _save_skeleton(args.save_skeleton, result, grid, protect + [args.output])
    if progress.enabled:
        total = sum(progress.timings.values())
        print(f"wrote {args.output}: {len(out.vertices)} vertices, {len(out.faces)} faces "
              f"({total:.1f} s)", file=sys.stderr)


def _save_skeleton(path, result, grid, protect):
    points, props = [], {"quality": [], "d": [], "rho": [], "sigma_bar": [], "rho_plus": [], "kept": [],
                         "stage": []}
    for stage_id, name in enumerate(("foreground", "background")):
        if name not in result.stages:
            continue
        s = result.stages[name].skeleton
        ijk = np.stack(np.unravel_index(s.voxels, grid.shape), axis=1)
        points.append(grid.to_world(ijk))
        for key, values in (("quality", s.rho_plus), ("d", s.distance), ("rho", s.rho),
                            ("sigma_bar", s.sigma_bar), ("rho_plus", s.rho_plus), ("kept", s.kept)):
            props[key].append(values)
        props["stage"].append(np.full(len(s.voxels), stage_id))
    io.save_point_cloud_ply(path, np.concatenate(points), {k: np.concatenate(v) for k, v in props.items()},
                            protect)


def _noise(args):
    params = _params(NoiseParams, args)
    mesh = io.load_mesh(args.input)
    progress = Progress(enabled=args.progress)
    noisy, _, _ = pipeline.noisy_mesh(mesh, params, progress)
    io.save_mesh(noisy, args.output, protect=[args.input])


def _compare(args):
    from comparisons.config import load_config
    from comparisons.run import Reporter, run_compare

    config = load_config(args.config, jobs=args.jobs, resolution=args.resolution)
    run_compare(config, args.out, Reporter(enabled=args.progress is not False))


def main(argv=None):
    args = build_parser().parse_args(argv)
    try:
        {"denoise": _denoise, "noise": _noise, "compare": _compare}[args.command](args)
    except SkelfilterError as exc:
        print(f"skelfilter: error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:
        print("skelfilter: error: out of memory; lower --resolution", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
