"""A depth-camera scan of a mesh, as a real sensor makes it: a pixel grid of depths, triangulated.

What a structured-light or time-of-flight camera (a Kinect) does to a surface, modelled after what its
scans show (the shared ``realscan/kinect-pyramid``): the depth is measured per pixel along the view ray
and

- carries *low-frequency* noise: a smooth random field over the image (Gaussian-filtered white noise,
  correlation ``waves_px`` pixels), which turns a flat face into waves over several vertices;
- is *quantized* (``step`` of the pixel spacing): neighbouring pixels share a depth, so the mesh is
  terraced, with flat pairs of triangles between steps;
- *flares* at depth edges: pixels near a jump in depth are pulled towards the far side;
- has a little white noise on top.

The pixels are triangulated two triangles per quad, where the four depths are valid and no jump
larger than ``jump`` pixel spacings separates them. The scan is an open surface (one view). Used by
the routing corpus (``benchmarks/routing_corpus.py``) as a stand-in for real sensor noise.
"""

import numpy as np
import trimesh
from scipy import ndimage

from benchmarks.range_scan import orthographic_rays


def depth_scan(mesh, view=(0.4, -1.0, 0.7), pixels=120, waves=1.0, waves_px=2.5, step=0.5, white=0.1,
               flare=1.5, jump=3.0, seed=1):
    """The surface of ``mesh`` seen from ``view`` by a depth camera (orthographic), and its truth.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    view : 3 floats
        Direction from the mesh's centre to the camera.
    pixels : int
        Pixels per side of the image, which covers the mesh's bounding sphere.
    waves, step, white, flare : float
        Amplitude of the low-frequency noise (standard deviation), the depth quantization step, the
        white noise (standard deviation) and the flare at depth edges, all in pixel spacings.
    waves_px : float
        Correlation length of the low-frequency noise, in pixels.
    jump : float
        Depth difference (pixel spacings) across which neighbouring pixels are not joined.
    seed : int

    Returns
    -------
    scan, truth : trimesh.Trimesh
        The open scan in ``mesh``'s coordinates, and the same pixels at their true depths (same
        vertices and faces; ``process=False``).
    """
    rng = np.random.default_rng(seed)
    direction, origins, spacing, hit = orthographic_rays(mesh, view, pixels)
    depth = hit["t_hit"].numpy().reshape(pixels, pixels).astype(np.float64) / spacing
    valid = np.isfinite(depth)
    # grazing views are lost
    normals = hit["primitive_normals"].numpy().reshape(pixels, pixels, 3)
    valid &= np.abs(normals @ direction) > 0.15
    true_depth = depth.copy()
    far = np.where(valid, depth, np.nanmax(np.where(valid, depth, -np.inf)) + 10 * jump)
    # flare: pixels beside a deeper neighbour are pulled towards it
    deeper = ndimage.maximum_filter(far, size=3) - far
    depth = depth + np.where(deeper > jump, flare * rng.uniform(0.3, 1.0, depth.shape), 0.0)
    smooth = ndimage.gaussian_filter(rng.normal(size=depth.shape), waves_px)
    smooth *= waves / max(smooth.std(), 1e-12)
    depth = depth + smooth + rng.normal(0.0, white, depth.shape)
    if step > 0:
        depth = np.round(depth / step) * step
    grid_origins = origins.reshape(pixels, pixels, 3)
    points = grid_origins - direction * (depth * spacing)[..., None]
    truth_points = grid_origins - direction * (np.where(valid, true_depth, 0.0) * spacing)[..., None]
    index = np.arange(pixels * pixels).reshape(pixels, pixels)
    quads = np.stack([index[:-1, :-1], index[1:, :-1], index[1:, 1:], index[:-1, 1:]], axis=-1).reshape(-1, 4)
    flat_depth, flat_valid = depth.reshape(-1), valid.reshape(-1)
    corner_depth = flat_depth[quads]
    ok = flat_valid[quads].all(axis=1) & (np.ptp(np.where(flat_valid[quads], corner_depth, 0.0), axis=1) < jump)
    quads = quads[ok]
    faces = np.concatenate([quads[:, [0, 2, 1]], quads[:, [0, 3, 2]]])
    used = np.unique(faces)
    faces = np.searchsorted(used, faces)
    truth = trimesh.Trimesh(truth_points.reshape(-1, 3)[used], faces, process=False)
    if np.mean(truth.face_normals @ direction) < 0:  # faces wound to face the camera
        faces = faces[:, ::-1].copy()
        truth = trimesh.Trimesh(truth.vertices, faces, process=False)
    return trimesh.Trimesh(points.reshape(-1, 3)[used], faces.copy(), process=False), truth
