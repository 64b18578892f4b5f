"""Quality figures of the thesis' pipeline (preset ``thesis``) on the test shapes (prints a table, optional JSON).

The project's own quality benchmark, which chose the default preset, is ``benchmarks/quality.py``.

    python -m benchmarks.acceptance [--resolution 160] [--json out.json]

Noise removal: the thesis' stripes (p = 0.014, r = 2.1, h = 3, l = 6) on a cube and on fandisk,
with and without dents, fixed seeds, scored voxel by voxel on the noise grid:
removed = share of the added noise voxels gone from the result (bumps: not in it; dents: in it),
lost = share of the clean volume lost away from the noise (clean voxels farther than h + r + 1 from
any noise voxel that the result no longer has).
"""

import argparse
import json
import os
import sys

import numpy as np
import trimesh
from scipy import ndimage

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..")
PRESET = "thesis-tuned"


def load(name):
    return trimesh.load(os.path.join(ROOT, "skelfilter", "data", name), force="mesh", process=False)


def cube_mesh():
    return trimesh.creation.box((1.0, 1.0, 1.0))


def noise_scores(clean, noise, result, reach):
    near_noise = ndimage.distance_transform_edt(~(noise.bumps | noise.dents)) <= reach
    scores = {}
    if noise.bumps.any():
        scores["bumps_removed"] = 1.0 - (result & noise.bumps).sum() / noise.bumps.sum()
    if noise.dents.any():
        scores["dents_removed"] = (result & noise.dents).sum() / noise.dents.sum()
    far = clean & ~near_noise
    scores["clean_lost_away_from_noise"] = (far & ~result).sum() / clean.sum()
    scores["added_outside_clean_and_noise"] = (result & ~clean & ~noise.bumps).sum() / clean.sum()
    return scores


def denoising_rows(resolution, seed=1):
    from skelfilter import add_noise, denoise_volume
    from skelfilter.mesh.voxelize import voxelize

    rows = []
    for name, mesh in (("cube", cube_mesh()), ("fandisk", load("fandisk.obj"))):
        clean, _ = voxelize(mesh, resolution, 16)
        for dents in (False, True):
            noise = add_noise(clean, p=0.014, r=2.1, h=3, l=6, seed=seed, dents=dents)
            result = denoise_volume(noise.noisy, preset=PRESET).mask
            row = {"shape": name, "dents": dents, "noise_voxels": int((noise.bumps | noise.dents).sum())}
            row.update(noise_scores(clean, noise, result, 3 + 2.1 + 1))
            rows.append(row)
    return rows


def property_rows(resolution):
    from skelfilter import denoise_mesh, denoise_volume
    from skelfilter.mesh.voxelize import voxelize

    rows = {}
    for name, mesh in (("cube", cube_mesh()), ("fandisk", load("fandisk.obj"))):
        clean, _ = voxelize(mesh, resolution, 8)
        for edt_filter in ("none", "minify"):
            out = denoise_volume(clean, edt_filter=edt_filter, preset=PRESET).mask
            rows[f"clean {name} changed ({edt_filter})"] = (out ^ clean).sum() / clean.sum()
        out = denoise_volume(clean, preset=PRESET).mask
        lost = np.argwhere(clean & ~out)
        if len(lost):
            box = np.argwhere(clean)
            lo, hi = box.min(0), box.max(0)
            rows[f"minify: deepest cut at {name} edges (voxels)"] = float(
                np.sort(np.minimum(lost - lo, hi - lost), axis=1)[:, 1].max()) if name == "cube" else float("nan")
        twice = denoise_volume(out, preset=PRESET).mask
        rows[f"second pass changes ({name})"] = (out ^ twice).sum() / out.sum()
    bunny = load("stanford-bunny.obj")
    out = denoise_mesh(bunny, resolution=resolution, preset=PRESET)
    rows["bunny out watertight"] = bool(out.is_watertight)
    rows["bunny out bodies"] = len(out.split(only_watertight=False))
    clean, grid = voxelize(bunny, resolution, 8)
    from skelfilter.mesh.voxelize import voxelize_on_grid

    back = voxelize_on_grid(out, grid)
    top = np.zeros_like(clean)
    ys = np.argwhere(clean)[:, 1]
    top[:, int(ys.min() + 0.8 * (ys.max() - ys.min())):, :] = True  # the ears: top fifth of the height
    rows["bunny ear voxels kept"] = (back & clean & top).sum() / (clean & top).sum()
    rocker = load("rocker-arm.obj")
    out = denoise_mesh(rocker, resolution=resolution, preset=PRESET)
    rows["rocker-arm genus in/out"] = f"{(2 - rocker.euler_number) // 2}/{(2 - out.euler_number) // 2}"
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--resolution", type=int, default=160)
    parser.add_argument("--json")
    args = parser.parse_args()
    rows = denoising_rows(args.resolution)
    print(f"noise removal at {args.resolution} voxels (stripes p=0.014 r=2.1 h=3 l=6, seed 1)")
    print(f"{'shape':8s} {'dents':6s} {'noise vox':>10s} {'bumps rem.':>10s} {'dents rem.':>10s} "
          f"{'clean lost':>10s} {'added':>8s}")
    for r in rows:
        print(f"{r['shape']:8s} {str(r['dents']):6s} {r['noise_voxels']:10d} {r.get('bumps_removed', 0):10.3f} "
              f"{r.get('dents_removed', float('nan')):10.3f} {r['clean_lost_away_from_noise']:10.4f} "
              f"{r['added_outside_clean_and_noise']:8.4f}")
    props = property_rows(args.resolution)
    print(f"\nproperties at {args.resolution} voxels")
    for k, v in props.items():
        print(f"  {k:45s} {v:.4f}" if isinstance(v, float) else f"  {k:45s} {v}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"denoising": rows, "properties": {k: str(v) for k, v in props.items()}}, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
