"""What the default does with one isolated spur: a 40-voxel box segmentation with a single 2 x 2 spur
of 1-3 voxels on its top face, denoised as it is and with a given noise height.

    python -m experiments.lone_spur

Prints, per spur height and noise height, the spur voxels left and the box voxels lost.
"""

import numpy as np

from skelfilter.core import pipeline

HEIGHTS = (1, 2, 3)  # voxels
NOISE_HEIGHTS = (None, 2.0, 3.0, 4.0)  # None: the default's own estimate


def main():
    box = np.zeros((60, 60, 60), dtype=bool)
    box[10:50, 10:50, 10:50] = True
    print("| spur height | " + " | ".join("estimated" if h is None else f"noise height {h:g}"
                                          for h in NOISE_HEIGHTS) + " |")
    print("|---|" + "---|" * len(NOISE_HEIGHTS))
    for height in HEIGHTS:
        noisy = box.copy()
        noisy[29:31, 29:31, 50:50 + height] = True
        spur = noisy & ~box
        cells = []
        for noise_height in NOISE_HEIGHTS:
            given = {} if noise_height is None else {"noise_height": noise_height, "prune": "as-told"}
            out = pipeline.denoise_volume(noisy, **given)
            cells.append(f"{int((out.mask & spur).sum())} of {int(spur.sum())} left, "
                         f"{int((box & ~out.mask).sum())} lost")
        print(f"| {height} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
