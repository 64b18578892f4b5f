"""What one label of a large segmentation costs: `skelfilter denoise map.npy out.npy --label 4
--spacing 1 1 1.5` on a made-up label map of the size of pyvista's frog tissue map (500 x 470 x 136
voxels, 1 x 1 x 1.5 mm), whose label 4 is a 37 000-voxel organ with segmentation-like noise.

    python -m benchmarks.label_cost [--repeat 3]

Prints the best wall time of fresh processes and their peak memory.
"""

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy import ndimage

SHAPE = (500, 470, 136)
SPACING = ("1", "1", "1.5")


def label_map(seed=0):
    """Label 1: a body filling most of the box; label 4: an organ in it, its surface wobbling."""
    rng = np.random.default_rng(seed)
    labels = np.zeros(SHAPE, dtype=np.uint8)
    z, y, x = np.ogrid[: SHAPE[0], : SHAPE[1], : SHAPE[2]]
    labels[((z - 250) / 220.0) ** 2 + ((y - 235) / 200.0) ** 2 + ((x - 68) / 60.0) ** 2 < 1] = 1
    wobble = np.zeros(SHAPE, dtype=np.float32)
    wobble[260:340, 165:235, 50:90] = 3 * ndimage.gaussian_filter(rng.normal(size=(80, 70, 40)).astype(np.float32),
                                                                  1.5)
    labels[((z - 300) / 28.0) ** 2 + ((y - 200) / 22.0) ** 2 + ((x - 70) / 14.0) ** 2 < 1 + wobble] = 4
    return labels


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeat", type=int, default=3, help="fresh processes (the best counts)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        source, out = os.path.join(tmp, "map.npy"), os.path.join(tmp, "out.npy")
        labels = label_map()
        np.save(source, labels)
        print(f"label map {SHAPE}, label 4: {int((labels == 4).sum())} voxels")
        best, peak = np.inf, 0
        for _ in range(args.repeat):
            start = time.perf_counter()
            subprocess.run([sys.executable, "-m", "skelfilter.cli", "denoise", source, out, "--label", "4",
                            "--spacing", *SPACING, "--quiet"], check=True)
            best = min(best, time.perf_counter() - start)
            peak = max(peak, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)  # KiB, the largest child
        print(f"skelfilter denoise --label 4 --spacing {' '.join(SPACING)}: best {best:.2f} s of {args.repeat}, "
              f"peak {peak / 1024:.0f} MiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
