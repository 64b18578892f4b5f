"""A single-view range scan of a mesh: what one scanner position sees, cut by the view, with holes.

Rays from a pinhole camera hit the mesh; the faces they hit first form the scan (an open surface:
the back and the parts in shadow are missing). Holes of a few edge lengths are punched where a
scanner loses the signal, and Gaussian noise along the view rays is added, as a scanner measures
depth. Used for the open-scan fixture of the tests (``tests/data/range-scan-bunny.ply``) and the
open-surface checks of the README.

    python -m benchmarks.range_scan MESH OUT.ply [--seed 1] [--noise 0.2] [--holes 6] [--view X,Y,Z]
"""

import argparse

import numpy as np
import trimesh

from skelfilter.io import mesh_files as io


def orthographic_rays(mesh, view, pixels):
    """Rays of an orthographic camera looking at ``mesh`` from direction ``view``, cast (open3d).

    The image has ``pixels`` rays per side and covers the mesh's bounding sphere. Returns the unit
    view direction, the rays' origins ``(pixels * pixels, 3)`` (row-major over the image's two axes),
    the pixel spacing and open3d's cast result (``t_hit``, ``primitive_ids``, ``primitive_normals``).
    """
    import open3d as o3d

    direction = np.asarray(view, dtype=np.float64)
    direction /= np.linalg.norm(direction)
    centre, radius = mesh.bounding_sphere.primitive.center, mesh.bounding_sphere.primitive.radius
    u = np.cross(direction, [0.0, 0.0, 1.0] if abs(direction[2]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(direction, u)
    s = np.linspace(-radius, radius, pixels)
    a, b = np.meshgrid(s, s, indexing="ij")
    origins = centre + direction * 2 * radius + a.reshape(-1, 1) * u + b.reshape(-1, 1) * v
    rays = np.hstack([origins, np.broadcast_to(-direction, origins.shape)]).astype(np.float32)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.core.Tensor(np.asarray(mesh.vertices, dtype=np.float32)),
                        o3d.core.Tensor(np.asarray(mesh.faces, dtype=np.uint32)))
    return direction, origins, s[1] - s[0], scene.cast_rays(o3d.core.Tensor(rays))


def range_scan(mesh, view=(0.3, -1.0, 0.4), pixels=400, holes=6, noise=0.2, seed=1):
    """The part of ``mesh`` seen from direction ``view``, with ``holes`` holes and depth noise.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    view : 3 floats
        Direction from the mesh's centre to the camera.
    pixels : int
        Rays per side of the image (orthographic, covering the bounding sphere).
    holes : int
        Discs of 2-4 mean edge lengths removed around random seen vertices.
    noise : float
        Standard deviation of the depth noise along the view direction, in mean edge lengths.
    seed : int

    Returns
    -------
    trimesh.Trimesh
        The seen faces (unreferenced vertices dropped), an open surface.
    """
    import open3d as o3d

    rng = np.random.default_rng(seed)
    direction, _, _, hits = orthographic_rays(mesh, view, pixels)
    hit = hits["primitive_ids"].numpy()
    seen = np.zeros(len(mesh.faces), dtype=bool)
    seen[hit[hit != o3d.t.geometry.RaycastingScene.INVALID_ID]] = True
    seen &= mesh.face_normals @ direction > 0.1  # grazing faces are lost too
    scan = mesh.submesh([np.flatnonzero(seen)], append=True)
    scan = trimesh.Trimesh(scan.vertices, scan.faces, process=True)
    edge = scan.edges_unique_length.mean()
    keep = np.ones(len(scan.faces), dtype=bool)
    for centre_vertex in rng.choice(len(scan.vertices), size=holes, replace=False):
        r = edge * rng.uniform(2.0, 4.0)
        near = np.linalg.norm(scan.triangles_center - scan.vertices[centre_vertex], axis=1) < r
        keep &= ~near
    scan = scan.submesh([np.flatnonzero(keep)], append=True)
    scan = trimesh.Trimesh(scan.vertices, scan.faces, process=True)
    depth = rng.normal(0.0, noise * edge, len(scan.vertices))
    scan.vertices = scan.vertices + depth[:, None] * direction
    return scan


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("mesh")
    p.add_argument("out")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--noise", type=float, default=0.2, help="depth noise, mean edge lengths")
    p.add_argument("--holes", type=int, default=6)
    p.add_argument("--view", type=lambda t: tuple(float(x) for x in t.split(",")), default=(0.3, -1.0, 0.4),
                   help="direction to the camera, x,y,z")
    args = p.parse_args(argv)
    scan = range_scan(io.load_mesh(args.mesh), view=args.view, holes=args.holes, noise=args.noise,
                      seed=args.seed)
    io.save_mesh(scan, args.out)
    print(f"wrote {args.out}: {len(scan.vertices)} vertices, {len(scan.faces)} faces")


if __name__ == "__main__":
    main()
