"""Which output suits an input: the user's own mesh, smoothed, or a new closed solid.

Two measurements decide the ``auto`` output mesh of the default preset:

- `solid_share`: is the input a solid? Its voxelization fills whatever it encloses; when that
  closes only small holes (the bunny's base), nearly all of the voxel surface lies on the input
  mesh. An open surface (a relief, a single-view scan) gets a cap that lies far from it.
- `skeleton_noise_share`: does the input carry noise at the skeleton's scale? Bumps and stripes
  several voxels tall, removed by the pruning, stick out of the denoised shape (`protruding`) and
  rise at least `TALL` voxels above it; measured per voxel of the input's surface. Fine scanner
  noise gives almost none of that: what the pruning takes off such inputs is the shape's own relief
  (an ear's tip, the folds of a bust), which the fine pass keeps.

Chosen on `benchmarks/quality.py` (thesis-style noise: 0.22-2.4 on every case) and the
literature's pairs and clean shapes (0.00-0.25, the highest on the open relief Nicolo, which the
first test already sends to the kept mesh); see README "Output meshes".
"""

import numpy as np
from scipy import ndimage

from .vertex_projection import protruding

# Voxels of the input's voxel surface that must lie within `NEAR` voxels of the input mesh for the
# input to count as a solid.
SOLID_SHARE = 0.98
NEAR = 2.0
# Protruding removed voxels at least `TALL` voxels from the denoised shape, per surface voxel, from
# which the input counts as covered in skeleton-scale noise.
TALL = 2.0
NOISE_SHARE = 0.17


def surface_voxels(volume):
    """The set voxels with an unset 6-neighbour."""
    return volume & ~ndimage.binary_erosion(volume)


def solid_share(occupancy, mesh, grid):
    """Share of the voxel surface of ``occupancy`` within `NEAR` voxels of ``mesh``'s surface."""
    import open3d as o3d  # imported where used: it needs the system's libusb

    rim = np.argwhere(surface_voxels(occupancy))
    if len(rim) == 0:
        return 0.0
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, dtype=np.float32)),
                        o3d.core.Tensor(np.asarray(mesh.faces, dtype=np.uint32)))
    distance = scene.compute_distance(o3d.core.Tensor(grid.to_world(rim).astype(np.float32))).numpy()
    return float(np.mean(distance / grid.pitch <= NEAR))


def skeleton_noise_share(occupancy, mask):
    """Protruding removed voxels at least `TALL` voxels from ``mask``, per surface voxel of
    ``occupancy`` (the input voxels; ``mask`` the denoised ones)."""
    removed = protruding(occupancy & ~mask, mask)
    tall = removed & (ndimage.distance_transform_edt(~mask) >= TALL)
    return float(np.count_nonzero(tall) / max(np.count_nonzero(surface_voxels(occupancy)), 1))
