"""Which output suits an input: the user's own mesh, smoothed, or a new closed solid.

Three measurements decide the ``auto`` output mesh of the default preset:

- `is_closed`, `solid_share`: is the input a solid? A closed mesh is. Otherwise its voxelization
  fills whatever it encloses; when that closes only small holes (the bunny's base), nearly all of
  the voxel surface lies on the input mesh, while an open surface (a relief, a single-view scan)
  gets a cap that lies far from it.
- `skeleton_noise_layer`: does the input carry noise at the skeleton's scale? Bumps and stripes
  several voxels tall, removed by the pruning, stick out of the denoised shape (`protruding`) and
  rise at least `TALL` voxels above it; their volume over the input's surface is the mean thickness
  of that layer, given as a fraction of the model's size so that it does not depend on the grid.
  On clean shapes what the pruning takes off is the shape's own relief (an ear's tip, a fold), a
  thinner layer.
- the fine noise on the mesh itself (`skelfilter.normal_filtering.noise_level`): a scanner's
  noise turns every face away from its neighbours. Where it is strong the fine pass is the better
  tool and the voxel stage's verdict mixes that noise with real relief; voxel-derived meshes
  (marching cubes, segmentations) have a flat neighbour for every face.

A new closed mesh is made when the layer reaches `NOISE_LAYER` and the fine noise stays under
`FINE_NOISE`. Chosen on `benchmarks/quality.py` (thesis-style noise, seed 1 at 160: layer
0.00091-0.0110 of the size, fine noise at most 0.007), the clean shapes (layer at most 0.0003) and
the literature's pairs (fine noise 0.115-0.235); see README "Output meshes".
"""

import numpy as np
from scipy import ndimage

from . import normal_filtering
from .vertex_projection import protruding

# Voxels of the input's voxel surface that must lie within `NEAR` voxels of the input mesh for the
# input to count as a solid.
SOLID_SHARE = 0.98
NEAR = 2.0
# Removed voxels count as tall noise from `TALL` voxels above the denoised shape (the 26-neighbours of
# the shape are the voxels under 2 voxels from it); the input is
# covered in skeleton-scale noise from a mean layer of `NOISE_LAYER` of its size, with fine noise
# under `FINE_NOISE`.
TALL = 2.0
NOISE_LAYER = 6e-4
FINE_NOISE = 0.08
# Faces, or voxels, on which the shares above are measured at most (a random sample, fixed seed).
SAMPLE = 50_000


def surface_voxels(volume):
    """The set voxels with an unset 6-neighbour."""
    return volume & ~ndimage.binary_erosion(volume)


def is_closed(faces):
    """Whether every edge of the triangles ``faces`` is shared by an even number of them (no rim)."""
    faces = np.asarray(faces, dtype=np.int64)
    edges = np.sort(normal_filtering.face_edges(faces), axis=1)
    codes = edges[:, 0] * (int(faces.max()) + 1) + edges[:, 1]
    return bool(np.all(np.unique(codes, return_counts=True)[1] % 2 == 0))


def solid_share(occupancy, mesh, grid):
    """Share of the voxel surface of ``occupancy`` (at most `SAMPLE` of its voxels) within `NEAR`
    voxels of ``mesh``'s surface."""
    import open3d as o3d  # imported where used: it needs the system's libusb

    rim = np.argwhere(surface_voxels(occupancy))
    if len(rim) == 0:
        return 0.0
    if len(rim) > SAMPLE:
        rim = rim[np.random.default_rng(0).choice(len(rim), SAMPLE, replace=False)]
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, dtype=np.float32)),
                        o3d.core.Tensor(np.asarray(mesh.faces, dtype=np.uint32)))
    distance = scene.compute_distance(o3d.core.Tensor(grid.to_world(rim).astype(np.float32))).numpy()
    return float(np.mean(distance / grid.pitch <= NEAR))


def skeleton_noise_layer(occupancy, mask, resolution):
    """Mean thickness, as a fraction of the model's size, of the protruding removed voxels at least
    `TALL` voxels from ``mask`` spread over the surface of ``occupancy`` (the input voxels; ``mask``
    the denoised ones; ``resolution`` voxels along the model's longest side)."""
    removed = protruding(occupancy & ~mask, mask)
    # at least TALL = 2 voxels from the mask: outside its 26-neighbourhood (squared distances <= 3)
    tall = removed & ~ndimage.binary_dilation(mask, structure=np.ones((3, 3, 3), dtype=bool))
    surface = max(np.count_nonzero(surface_voxels(occupancy)), 1)
    return float(np.count_nonzero(tall) / surface / resolution)


def fine_noise(mesh, sample=SAMPLE, seed=0):
    """`skelfilter.normal_filtering.noise_level` of a mesh, on at most ``sample`` of its faces."""
    faces = np.asarray(mesh.faces, dtype=np.int64)
    normals = normal_filtering.face_normals(np.asarray(mesh.vertices, dtype=np.float64), faces)
    subset = None
    if len(faces) > sample:
        subset = np.sort(np.random.default_rng(seed).choice(len(faces), sample, replace=False))
    return normal_filtering.noise_level(normals, normal_filtering.face_neighbours(faces, len(mesh.vertices), subset))
