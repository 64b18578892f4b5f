"""Which output suits an input: the user's own mesh, smoothed, or a new closed solid.

Three measurements decide the ``auto`` output mesh of the default preset:

- `is_closed`, `solid_share`: is the input a solid? A closed mesh is. Otherwise its voxelization
  fills whatever it encloses; when that closes only small holes (the bunny's base), nearly all of
  the voxel surface lies on the input mesh, while an open surface (a relief, a single-view scan)
  gets a cap that lies far from it.
- does the input carry noise at the skeleton's scale? `skelfilter.core.noise_estimate` measures it on
  what the pruning removes (many low peaks all over the surface); the pipeline asks it.
- the fine noise on the mesh itself (`skelfilter.mesh.normal_filtering.noise_level`): a scanner's
  noise turns every face away from its neighbours. Where it is strong the fine pass is the better
  tool and the voxel stage's verdict mixes that noise with real relief; voxel-derived meshes
  (marching cubes, segmentations) have a flat neighbour for every face.

A new closed mesh is made when noise at the skeleton's scale is found and the fine noise stays under
`FINE_NOISE`. Chosen on `benchmarks/quality.py` (thesis-style noise, seed 1 at 160: fine noise at
most 0.007) and the literature's pairs (fine noise 0.115-0.235); see README "Output meshes".
"""

import numpy as np

from skelfilter.core.noise_estimate import surface_voxels
from skelfilter.mesh import normal_filtering
from skelfilter.mesh.closest_points import within

# Voxels of the input's voxel surface that must lie within `NEAR` voxels of the input mesh for the
# input to count as a solid.
SOLID_SHARE = 0.98
NEAR = 2.0
# From this fine noise the input mesh comes back smoothed by the fine pass, the voxel stage skipped.
FINE_NOISE = 0.08
# Under this fine noise a mesh has none: where the voxel stage changed nothing it comes back as it was,
# without the fine pass (clean meshes measure at most 0.037, the rocker arm; the literature's noisy
# pairs from 0.115, Bunny0.2).
CLEAN_FINE_NOISE = 0.06
# Faces, or voxels, on which the shares above are measured at most (a random sample, fixed seed).
SAMPLE = 50_000


def is_closed(faces):
    """Whether every edge of the triangles ``faces`` is shared by an even number of them (no rim)."""
    faces = np.asarray(faces, dtype=np.int64)
    edges = np.sort(normal_filtering.face_edges(faces), axis=1)
    codes = edges[:, 0] * (int(faces.max()) + 1) + edges[:, 1]
    return bool(np.all(np.unique(codes, return_counts=True)[1] % 2 == 0))


def solid_share(occupancy, mesh, grid):
    """Share of the voxel surface of ``occupancy`` (at most `SAMPLE` of its voxels) within `NEAR`
    voxels of ``mesh``'s surface."""
    rim = np.argwhere(surface_voxels(occupancy))
    if len(rim) == 0:
        return 0.0
    if len(rim) > SAMPLE:
        rim = rim[np.random.default_rng(0).choice(len(rim), SAMPLE, replace=False)]
    return float(np.mean(within(mesh, grid.to_world(rim), NEAR * grid.pitch)))


def fine_noise(mesh, sample=SAMPLE, seed=0):
    """`skelfilter.mesh.normal_filtering.noise_level` of a mesh, on at most ``sample`` of its faces."""
    faces = np.asarray(mesh.faces, dtype=np.int64)
    normals = normal_filtering.face_normals(np.asarray(mesh.vertices, dtype=np.float64), faces)
    subset = None
    if len(faces) > sample:
        subset = np.sort(np.random.default_rng(seed).choice(len(faces), sample, replace=False))
    return normal_filtering.noise_level(normals, normal_filtering.face_neighbours(faces, len(mesh.vertices), subset))
