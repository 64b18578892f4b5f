"""Running one method of the comparison on a noisy mesh, timed, with failures kept as data.

MeshLab's filters and MeshLib's denoiser are C++ that can crash; both run in a child process
(MeshLab through :func:`skelfilter.meshlab.scripts.run_filter_script`, MeshLib here), so a segmentation
fault, a timeout or NaN vertices become an ``Outcome`` with a reason and the comparison goes on.
"""

import os
import time
from dataclasses import dataclass

import numpy as np
import trimesh

from skelfilter.errors import SkelfilterError
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.meshlab import scripts
from skelfilter.runtime.child import run_child
from skelfilter.runtime.extras import need
from skelfilter.runtime.progress import Progress
from skelfilter.runtime.signals import temporary_folder


@dataclass
class Outcome:
    mesh: trimesh.Trimesh | None
    seconds: float
    error: str | None = None
    route: str | None = None  # skelfilter: what it ran and why, as it tells a user
    filtered: bool = True  # False for the references (the noisy input, the clean mesh)


def run_method(method, noisy, clean, config):
    """Apply ``method`` (a :class:`~skelfilter.evaluation.comparison.config.Method`) to ``noisy``; never raises on a
    failure of the method itself."""
    start = time.perf_counter()
    # Each step held (`skelfilter.runtime.signals.deferred`): an interrupt while numba boxed a kernel's
    # results crashed the process (a tuple with a missing array); it acts as the step ends.
    progress = Progress(enabled=False, shield=True)
    try:
        if method.kind == "noisy":
            mesh = noisy
        elif method.kind == "clean":
            mesh = clean
        elif method.kind == "skelfilter":
            mesh = mesh_pipeline.denoise_mesh(noisy, config.denoise_params(method), progress)
        elif method.kind == "meshlab":
            mesh = scripts.run_filter_script(noisy, method.script, timeout=config.timeout)
        elif method.kind == "meshlib":
            mesh = meshlib_denoise(noisy, method.params, timeout=config.timeout)
        else:
            raise ValueError(f"unknown method kind {method.kind!r}")
    except (SkelfilterError, MemoryError) as exc:
        return Outcome(None, time.perf_counter() - start, str(exc) or type(exc).__name__)
    route = "; ".join(progress.notes) if method.kind == "skelfilter" else None
    return Outcome(mesh, time.perf_counter() - start, route=route, filtered=method.kind not in ("noisy", "clean"))


def _meshlib_child(workdir):
    """Child process: mesh.npz + settings.npz -> MeshLib's meshDenoiseViaNormals -> result.npz."""
    mn = need("meshlib.mrmeshnumpy", "MeshLib's denoising")
    mm = need("meshlib.mrmeshpy", "MeshLib's denoising")

    with np.load(os.path.join(workdir, "mesh.npz")) as z:
        vertices, faces = z["vertices"], z["faces"]
        settings = {k[2:]: z[k].item() for k in z.files if k.startswith("s_")}
    mesh = mn.meshFromFacesVerts(faces, vertices)
    s = mm.DenoiseViaNormalsSettings()
    for key, value in settings.items():
        setattr(s, key, value)
    mm.meshDenoiseViaNormals(mesh, s)
    np.savez(os.path.join(workdir, "result.npz"), vertices=mn.getNumpyVerts(mesh),
             faces=mn.getNumpyFaces(mesh.topology))


def meshlib_denoise(mesh, settings=None, timeout=900):
    """MeshLib's ``meshDenoiseViaNormals`` (default settings unless given) in a child process.

    Vertex order and faces are kept: the filter only moves vertices.

    Raises
    ------
    SkelfilterError
        MeshLib missing, crashed, timed out, or returned non-finite vertices.
    """
    return _in_child("_meshlib_child", mesh, settings, timeout, "MeshLib")


def _pygel3d_child(workdir):
    """Child process: mesh.npz + settings.npz -> pygel3d's anisotropic_smooth -> result.npz."""
    hmesh = need("pygel3d.hmesh", "PyGEL3D's smoothing")

    with np.load(os.path.join(workdir, "mesh.npz")) as z:
        vertices, faces = z["vertices"].astype(np.float64), z["faces"]
        settings = {k[2:]: z[k].item() for k in z.files if k.startswith("s_")}
    m = hmesh.Manifold.from_triangles(vertices, faces)
    hmesh.anisotropic_smooth(m, settings.get("sharpness", 0.5), settings.get("iterations", 10))
    path = os.path.join(workdir, "result.obj")
    hmesh.obj_save(path, m)
    result = trimesh.load(path, process=False, force="mesh")
    np.savez(os.path.join(workdir, "result.npz"), vertices=result.vertices, faces=result.faces)


def pygel3d_smooth(mesh, settings=None, timeout=900):
    """pygel3d's ``hmesh.anisotropic_smooth`` (sharpness 0.5, 10 iterations unless given) in a child
    process; the mesh comes back as pygel3d writes it (its own vertex and face order).

    Raises
    ------
    SkelfilterError
        pygel3d missing, crashed, timed out, or returned non-finite vertices.
    """
    return _in_child("_pygel3d_child", mesh, settings, timeout, "pygel3d")


def _in_child(function, mesh, settings, timeout, what):
    """Run ``function`` of this module on ``mesh`` in a child process (files in a temporary folder)."""
    with temporary_folder("skelfilter-child-") as work:
        np.savez(os.path.join(work, "mesh.npz"), vertices=np.asarray(mesh.vertices, dtype=np.float64),
                 faces=np.asarray(mesh.faces, dtype=np.int32),
                 **{f"s_{k}": np.asarray(v) for k, v in (settings or {}).items()})
        proc = run_child("skelfilter.evaluation.comparison.methods", function, work, timeout, what)
        if proc.returncode != 0:
            tail = proc.stderr.decode("utf-8", "replace").strip().splitlines()[-1:]
            raise SkelfilterError(f"{what} failed (exit status {proc.returncode}): {' '.join(tail)}")
        with np.load(os.path.join(work, "result.npz")) as z:
            vertices, faces = z["vertices"].astype(np.float64), z["faces"]
    bad = ~np.isfinite(vertices).all(axis=1)
    if bad.any():
        raise SkelfilterError(f"{what} returned {int(bad.sum())} of {len(vertices)} vertices with NaN "
                              "or infinite coordinates")
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
