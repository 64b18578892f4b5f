"""How rough a surface is: its normals against a smooth fit of their neighbours', in degrees.

Noise turns the surface's normal this way and that over a few samples; a clean surface's normal turns
smoothly (a curved part), stays put (a flat face) or jumps along a line (an edge). So the surface is
sampled uniformly by area (`SAMPLES` points, each with the normal of the face it lies on), and at each
sample the normals of its `NEIGHBOURS` nearest samples are fitted by a linear function of position
(a least-squares fit of n(p) = a + B (p - p0)): the fit follows a curved part whatever its
curvature, and a flat face exactly. The roughness is the median over the samples of the RMS angle
between a neighbour's normal and the fit's.

Because the samples lie by area, not by vertex, the measure does not depend on how the mesh stores
its vertices (an STL file keeps every triangle's corners apart) nor on its tessellation: a coarse
low-poly mesh is flat between its edges (0-4°), the same shape finely tessellated curved and smooth,
while Gaussian vertex noise, a depth camera's waves and terraces, or spikes thrown off the surface
leave a residual at every scale (6-50°). Measured on ``benchmarks/routing.py``'s corpus
(``docs/routing.md``).

The same residual after each sample's normal is averaged over its `COARSE_NEIGHBOURS` nearest samples
(`coarse_roughness`) tells noise that stands several samples wide (the thesis' bumps, 16-24°) from
vertex noise, which the averaging takes out (3-10°, up to 17° at 0.7 edge lengths).
"""

import numpy as np
from scipy.spatial import cKDTree

SAMPLES = 20_000
NEIGHBOURS = 12
COARSE_NEIGHBOURS = 16
SEED = 0


def surface_samples(vertices, faces, count=SAMPLES, seed=SEED):
    """``count`` points uniform by area on the triangles, and the unit normal of the face of each.

    Degenerate faces (no area) are never drawn. Returns ``(points, normals)``, both ``(count, 3)``,
    or two empty arrays for a mesh without area.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    corners = vertices[np.asarray(faces, dtype=np.int64)]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    double_area = np.linalg.norm(cross, axis=1)
    total = double_area.sum()
    if not total > 0:
        return np.empty((0, 3)), np.empty((0, 3))
    rng = np.random.default_rng(seed)
    chosen = rng.choice(len(corners), count, p=double_area / total)
    u = rng.random((count, 2))
    folded = u.sum(axis=1) > 1
    u[folded] = 1.0 - u[folded]
    tri = corners[chosen]
    points = tri[:, 0] + u[:, :1] * (tri[:, 1] - tri[:, 0]) + u[:, 1:] * (tri[:, 2] - tri[:, 0])
    return points, cross[chosen] / double_area[chosen, None]


def residual_angles(points, normals, neighbours=NEIGHBOURS):
    """Per sample: the RMS angle (degrees) between its ``neighbours`` nearest samples' normals (and its
    own) and their least-squares linear fit in position."""
    k = min(neighbours + 1, len(points))
    distance, index = cKDTree(points).query(points, k, workers=-1)
    offsets = points[index] - points[:, None, :]
    scale = distance[:, -1:, None]
    scale[scale == 0] = 1.0
    design = np.concatenate([np.ones(offsets.shape[:2] + (1,)), offsets / scale], axis=2)
    target = normals[index]
    transposed = design.transpose(0, 2, 1)
    coefficients = np.linalg.solve(transposed @ design + 1e-6 * np.eye(4), transposed @ target)
    rest = target - design @ coefficients
    rms = np.sqrt(np.einsum("nkj,nkj->n", rest, rest) / k)
    return np.degrees(2.0 * np.arcsin(np.clip(rms / 2.0, 0.0, 1.0)))


def roughness(points, normals):
    """The median `residual_angles` of `surface_samples`, in degrees (0 for no samples)."""
    if len(points) == 0:
        return 0.0
    return float(np.median(residual_angles(points, normals)))


def coarse_roughness(points, normals, faces_count):
    """`roughness` of the normals of `surface_samples` averaged over each sample's nearest samples, on
    a fifth of the samples: what stands wider than a few faces. The average takes `COARSE_NEIGHBOURS`
    samples or, on a mesh of fewer faces than samples, as many more as a face holds: it spans about
    `COARSE_NEIGHBOURS` faces however the mesh is tessellated."""
    if len(points) == 0:
        return 0.0
    per_face = max(len(points) / max(faces_count, 1), 1.0)
    index = cKDTree(points).query(points, min(int(np.ceil(COARSE_NEIGHBOURS * per_face)), len(points)), workers=-1)[1]
    averaged = normals[index].mean(axis=1)
    length = np.linalg.norm(averaged, axis=1, keepdims=True)
    averaged = np.divide(averaged, length, out=np.zeros_like(averaged), where=length > 0)
    subset = np.random.default_rng(SEED + 1).choice(len(points), max(len(points) // 5, 1), replace=False)
    return float(np.median(residual_angles(points[subset], averaged[subset])))
