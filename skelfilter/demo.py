"""The embedded sample: fandisk + the thesis' stripes, denoised, with a before/after picture.

``python -m skelfilter.demo --out demo-output``
"""

import argparse
import os
import sys
import time

from skelfilter.evaluation import camera, figures
from skelfilter.io import mesh_files
from skelfilter.io.samples import sample_path
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.mesh import voxelize
from skelfilter.params import DenoiseParams, NoiseParams
from skelfilter.runtime.progress import Progress


def run(out_dir, resolution=160, seed=1, progress=None):
    """Make the noisy sample, denoise it and write meshes, a picture and a summary."""
    os.makedirs(out_dir, exist_ok=True)
    progress = progress or Progress(enabled=False)
    clean = mesh_files.load_mesh(sample_path())
    noise_params = NoiseParams(resolution=resolution, seed=seed)
    with progress.stage("noise"):
        noisy, noise_result, grid = mesh_pipeline.noisy_mesh(clean, noise_params, progress)
    start = time.perf_counter()
    with progress.stage("denoise"):
        denoised = mesh_pipeline.denoise_mesh(noisy, DenoiseParams(resolution=resolution), progress)
    elapsed = time.perf_counter() - start
    # Score the output mesh voxel by voxel on the grid the noise was made on.
    result = voxelize.voxelize_on_grid(denoised, grid)
    removed = 1.0 - (result & noise_result.bumps).sum() / max(1, noise_result.bumps.sum())
    paths = {name: os.path.join(out_dir, f"{name}.ply") for name in ("clean", "noisy", "denoised")}
    for name, mesh in (("clean", clean), ("noisy", noisy), ("denoised", denoised)):
        mesh_files.save_mesh(mesh, paths[name])
    picture = os.path.join(out_dir, "before-after.png")
    figures.save_panels([noisy, denoised, clean], ["noisy", "skelfilter", "clean"], picture,
                        up=camera.up_for(sample_path()))
    summary = (f"fandisk at {resolution} voxels, stripes p={noise_params.p} r={noise_params.r} "
               f"h={noise_params.h} l={noise_params.l}: {noise_result.bumps.sum()} noise voxels, "
               f"{100 * removed:.1f}% removed; denoising took {elapsed:.1f} s")
    with open(os.path.join(out_dir, "summary.txt"), "w") as f:
        f.write(summary + "\n")
    return summary, paths, picture


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m skelfilter.demo", description=__doc__)
    parser.add_argument("--out", default="demo-output", help="output folder")
    parser.add_argument("--resolution", type=int, default=160)
    args = parser.parse_args(argv)
    summary, paths, picture = run(args.out, args.resolution, progress=Progress(enabled=True, shield=True))
    print(summary)
    for p in list(paths.values()) + [picture]:
        print("wrote", p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
