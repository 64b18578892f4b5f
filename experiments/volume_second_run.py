"""Could the volume path decide without its second run? Two decisions measured against the default's.

    python -m experiments.volume_second_run [--resolution 128] [--shapes a,b] [--out volume-second-run.jsonl]

The volume path (`skelfilter.core.pipeline._fine_pass_then_stages`) runs the foreground stage on the
volume after the fine pass; where that stage still finds noise at the skeleton's scale, the fine pass
is undone and the stages run again on the input: two runs of the skeleton core. For every shape of
`shapes.SHAPES` under the volume benchmark's segmentation noise (`volumes.STRENGTHS`) and the quality
benchmark's kinds stripes, bumps-dents, high and sparse, one line of JSON: the input's own foreground
estimate and the smoothed volume's (``input``, ``smoothed``: found, height in voxels, coverage), whether
the first predicts the second, and where only the input's finds noise, the error against the clean mask
(|out xor clean| / |noisy xor clean|) of the default (``default``) and of the stages on the input alone
(``input_only``, fine pass off: what a path deciding on the input's estimate alone would return).
Read in docs/performance.md (the volume path).
"""

import argparse
import json
import sys

import numpy as np

from benchmarks import quality, shapes, volumes
from skelfilter.core import pipeline
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.params import DenoiseParams
from skelfilter.runtime.progress import Progress

KINDS = (*volumes.STRENGTHS, "stripes", "bumps-dents", "high", "sparse")


def noisy_and_clean(shape, kind, resolution, seed=1):
    """The noisy mask and its clean one: segmentation noise (`volumes`) or the thesis' (`quality`)."""
    if kind in volumes.STRENGTHS:
        clean = volumes.clean_mask(shape, resolution)
        return volumes.segmentation_noise(clean, *volumes.STRENGTHS[kind], seed), clean
    _, noise, _ = mesh_pipeline.noisy_mesh(shapes.load(shape), quality.Case(shape, kind, seed).noise(resolution))
    return noise.noisy, noise.clean


def estimates(noisy):
    """The foreground estimates of the input and of the fine pass's result (None where the fine pass
    changed nothing), as the default computes them."""
    params, progress = DenoiseParams(), Progress(enabled=False)
    cropped = noisy[pipeline._crop(noisy)]  # what the stages see: the set's box (`pipeline._denoise_volume`)
    on_input = pipeline._foreground_first(cropped, params, progress)[1][1]
    smoothed, _ = pipeline.volume_fine_pass.fine_pass(cropped)
    on_smoothed = None
    if smoothed is not cropped:
        on_smoothed = pipeline._foreground_first(smoothed, params, progress)[1][1]
    return on_input, on_smoothed


def reading(estimate):
    return None if estimate is None else {"found": bool(estimate.found), "height": round(float(estimate.height), 2),
                                          "coverage": round(float(estimate.coverage), 4)}


def run_case(shape, kind, resolution):
    noisy, clean = noisy_and_clean(shape, kind, resolution)
    on_input, on_smoothed = estimates(noisy)
    row = {"shape": shape, "kind": kind, "input": reading(on_input), "smoothed": reading(on_smoothed)}
    if on_smoothed is not None and on_input.found and not on_smoothed.found:
        base = max(np.count_nonzero(noisy ^ clean), 1)
        for name, params in (("default", DenoiseParams()), ("input_only", DenoiseParams(fine_pass="off"))):
            out = pipeline.denoise_volume(noisy, params).mask
            row[name] = round(np.count_nonzero(out ^ clean) / base, 3)
    return row


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--resolution", type=int, default=128)
    parser.add_argument("--shapes", default=",".join(sorted(shapes.SHAPES)))
    parser.add_argument("--out", default="volume-second-run.jsonl")
    args = parser.parse_args(argv)
    with open(args.out, "w") as out:
        for shape in args.shapes.split(","):
            for kind in KINDS:
                row = run_case(shape, kind, args.resolution)
                print(json.dumps(row), file=out, flush=True)
                print(json.dumps(row), flush=True)


if __name__ == "__main__":
    sys.exit(main())
