"""Issue 51's noise handles: where the default's tunnels come from, and what closes them.

    python -m experiments.noise_handles [--shapes cube bunny ...] [--kinds stripes bumps-dents ...]
                                        [--seed 1] [--resolution 160] [--meshes [--cache DIR]]

Every case runs the volume path on the noise grid's noisy mask (``denoise_volume``, fine pass off, as
the thesis' noise at 160 voxels runs on meshes) and prints the voxel genus (`metrics.voxel_genus`,
26-connected) along the way: the input, the pruned reconstruction K, K with the features given back,
after the two-sided decision, the result with ``noise_handles`` keep (the default; specks and needles
off it too), then with ``noise_handles`` close. Then what closings of the kept result would do
instead: a plain closing by the 6-neighbour cross, by the 3x3x3 cube, by Euclidean balls of 2 and 3
voxels, and the same holes filled only where they close a tunnel (`noise_handles.filled_noise_handles`
takes the cross); then the dual, the bridges an opening by the cross removes, cut only where the cut
opens a tunnel (`cut`: an arch of noise taken off rather than filled under), and that cut followed by
``noise_handles`` close. Each row: the genus, the voxel error |out xor clean| / |noisy xor clean|, new material
(voxels out of the clean shape and its bumps, over the clean volume) and clean lost (the clean shape
but its dents, over its volume).
"""

import argparse
import os

import numpy as np
from scipy import ndimage

from benchmarks import quality
from skelfilter.core import pipeline
from skelfilter.core.decision import feature_restore, noise_handles
from skelfilter.evaluation.metrics import voxel_genus
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.params import DenoiseParams

CROSS = ndimage.generate_binary_structure(3, 1)
FILL = noise_handles.filled_noise_handles  # the step itself: `on_meshes` puts `cut_mask_step` in its place and back


def genus(mask):
    return voxel_genus(mask)["genus"]


class Steps:
    """The voxel genus after each step of one `denoise_volume` run (wrapping the steps it calls)."""

    def __init__(self):
        self.genus = {}

    def __enter__(self):
        self._keep, self._both = feature_restore.keep_features, pipeline._both_sides

        def keep(current, stage, *args, **kwargs):
            self.genus["pruned K"] = genus(stage.mask)
            found = self._keep(current, stage, *args, **kwargs)
            self.genus["features kept"] = genus(stage.mask)
            return found

        def both(volume, current, field, progress):
            out = self._both(volume, current, field, progress)
            self.genus["both sides"] = genus(out[0])
            return out

        feature_restore.keep_features, pipeline._both_sides = keep, both
        return self

    def __exit__(self, *exc):
        feature_restore.keep_features, pipeline._both_sides = self._keep, self._both


def topological(mask, closed):
    """``mask`` with the pieces of ``closed`` \\ ``mask`` that close a tunnel (the rule of
    `noise_handles.filled_noise_handles`, on any closing)."""
    holes = closed & ~mask
    labels, count = ndimage.label(holes, noise_handles.CUBE)
    rises = noise_handles.euler_change(mask, holes, labels, count) > 0
    rises[0] = False
    return mask | rises[labels]


def cut(mask):
    """``mask`` less the pieces of what an opening by the cross removes whose removal cuts a tunnel: it
    raises the Euler characteristic, and the piece touches one piece of the rest only (a cut that
    splits a part off raises it too)."""
    bridges = mask & ~ndimage.binary_opening(mask, CROSS)
    labels, count = ndimage.label(bridges, noise_handles.CUBE)
    rest = mask & ~bridges
    # The pieces touch no common cell: chi(mask) - chi(mask less piece k) is piece k's change on the rest.
    rises = noise_handles.euler_change(rest, bridges, labels, count) < 0
    rises[noise_handles._joining(rest, labels, count)] = False
    rises[0] = False
    return mask & ~rises[labels]


def closings(kept):
    plain = {
        "closing, cross": ndimage.binary_closing(kept, CROSS),
        "closing, cube": ndimage.binary_closing(kept, noise_handles.CUBE),
        "closing, ball 2": feature_restore.ball_closing(kept, 2.0),
        "closing, ball 3": feature_restore.ball_closing(kept, 3.0),
    }
    yield from plain.items()
    for label, closed in plain.items():
        yield f"{label}, tunnels only", topological(kept, closed)
    cut_off = cut(kept)
    yield "opening by the cross, tunnels only (cut)", cut_off
    yield "cut, then noise_handles close", cut_off | noise_handles.filled_noise_handles(cut_off)[0]


def row(name, label, out, noise):
    """One table row of ``out`` against the case's ``noise`` masks."""
    clean = noise.clean
    base = max(np.count_nonzero(noise.noisy ^ clean), 1)
    print(f"| {name} | {label} | {genus(out)} | {np.count_nonzero(out ^ clean) / base:.3f} | "
          f"{np.count_nonzero(out & ~clean & ~noise.bumps) / clean.sum():.4f} | "
          f"{np.count_nonzero(clean & ~out & ~noise.dents) / clean.sum():.4f} |", flush=True)


def on_meshes(args):
    """The quality benchmark's way (the noisy marching-cubes mesh, ``--resolution``): keep, close, and
    cut then close, scored by `quality.score` (Chamfer, the mesh's genus, its voxels' genus)."""
    setup = quality.Setup(resolution=args.resolution, cache=args.cache, refresh=False, timeout=600)
    print("| case | variant | mesh genus | voxel genus | Chamfer | new | clean lost |")
    print("|---|---|---|---|---|---|---|")
    for shape in args.shapes:
        for kind in args.kinds:
            case = quality.Case(shape, kind, args.seed)
            quality.prepare(case, setup)
            prep = quality.load_case(case, setup)
            clean_genus = quality.metrics.genus(prep.clean, prep.grid, prep.noise.clean)["genus"]
            noisy = quality.score(prep.marching, prep)
            print(f"| {case.name} | clean / input | {clean_genus} / {noisy['genus']} | | {noisy['chamfer']:.3f} | | |")
            for label, handles in (("keep (default)", "keep"), ("close", "close"), ("cut, then close", "cut")):
                params = DenoiseParams(resolution=args.resolution,
                                       noise_handles="keep" if handles == "keep" else "close")
                if handles == "cut":
                    noise_handles.filled_noise_handles = cut_mask_step
                try:
                    scores = quality.score(mesh_pipeline.denoise_mesh(prep.marching, params), prep)
                finally:
                    noise_handles.filled_noise_handles = FILL
                print(f"| {case.name} | {label} | {scores['genus']} | {scores['voxel_genus']} | "
                      f"{scores['chamfer']:.3f} | {100 * scores['new_material']:.2f} % | "
                      f"{100 * scores['clean_lost']:.2f} % |", flush=True)


def cut_mask_step(mask):
    """The pipeline's noise-handles step made cut-then-close: the voxels it flips (the cut ones and the
    filled ones) through the mask it is handed, which the step ORs with the fill."""
    cut_off = cut(mask)
    mask &= cut_off  # the pipeline's mask, in place: the cut voxels go
    return FILL(cut_off)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--shapes", nargs="+", default=["cube", "bunny"])
    parser.add_argument("--kinds", nargs="+", default=["stripes", "bumps-dents"], choices=sorted(quality.NOISE_KINDS))
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--resolution", type=int, default=160)
    parser.add_argument("--meshes", action="store_true",
                        help="the quality benchmark's meshes instead: keep, close, cut then close")
    parser.add_argument("--cache", default=os.path.join(quality.ROOT, "benchmark-cache"), help="noisy meshes' cache")
    args = parser.parse_args(argv)
    if args.meshes:
        on_meshes(args)
        return
    params = DenoiseParams(fine_pass="off")
    print("| case | step or variant | genus | voxel error | new | clean lost |\n|---|---|---|---|---|---|")
    for shape in args.shapes:
        for kind in args.kinds:
            case = quality.Case(shape, kind, args.seed)
            _, noise, _ = mesh_pipeline.noisy_mesh(quality.shapes.load(shape), case.noise(args.resolution))
            row(case.name, "clean", noise.clean, noise)
            row(case.name, "input", noise.noisy, noise)
            with Steps() as steps:
                kept = pipeline.denoise_volume(noise.noisy, params).mask
            for step, value in steps.genus.items():
                print(f"| {case.name} | {step} | {value} | | | |")
            row(case.name, "noise handles keep (default)", kept, noise)
            closed = pipeline.denoise_volume(noise.noisy, params.with_(noise_handles="close")).mask
            row(case.name, "noise handles close", closed, noise)
            for label, out in closings(kept):
                row(case.name, label, out, noise)


if __name__ == "__main__":
    main()
