"""One input file to one output file, whatever their kinds: the work of ``skelfilter denoise``, shared
with ``skelfilter batch``.

The kind of a file comes from its name: a volume (NIfTI, NRRD, TIFF, .npy; see
:mod:`skelfilter.volume_io`), else a mesh (PLY, OBJ, STL, OFF, GLB). A mesh comes out as a mesh; a
volume as a volume (its format, grid, header and affine) or as a mesh in the scanner's world
coordinates. Every path is checked before anything is read or computed.
"""

import os

import numpy as np

from . import io, pipeline, surface, volume_io
from .errors import InputError
from .params import VolumeParams
from .progress import Progress


def file_kind(path):
    """``volume`` or ``mesh``, from the name.

    Raises
    ------
    InputError
        Neither a volume nor a mesh format.
    """
    if volume_io.volume_format(path) is not None:
        return "volume"
    ext = os.path.splitext(str(path))[1].lower().lstrip(".")
    if ext in io.MESH_FORMATS:
        return "mesh"
    raise InputError(f"{path}: unsupported format {ext!r} (meshes: {', '.join(io.MESH_FORMATS)}; volumes: "
                     f"{', '.join(s.lstrip('.') for s in volume_io.VOLUME_SUFFIXES)})")


def check_paths(input_path, output_path, save_skeleton=None):
    """Refuse an impossible pair of paths before anything runs; returns (input kind, output kind).

    Raises
    ------
    InputError
        An unsupported format, a volume output for a mesh input, an output that is the input or
        sits in a missing folder, a skeleton file that is not a new .ply, or one asked of a volume.
    """
    kind_in, kind_out = file_kind(input_path), file_kind(output_path)
    if kind_in == "mesh" and kind_out == "volume":
        raise InputError(f"{output_path}: a mesh input gives a mesh output (use one of "
                         f"{', '.join(io.MESH_FORMATS)})")
    io.check_output(output_path, [input_path])
    if save_skeleton:
        if kind_in == "volume":
            raise InputError("--save-skeleton needs a mesh input")
        io.check_output(save_skeleton, {input_path: "input", output_path: "output"}, ("ply",))
    return kind_in, kind_out


def denoise_file(input_path, output_path, params, volume_params=None, save_skeleton=None, progress=None):
    """Denoise one file into another.

    Parameters
    ----------
    input_path, output_path : str
    params : DenoiseParams
    volume_params : VolumeParams, optional
        For a volume input: which voxels form the shape, the spacing.
    save_skeleton : str, optional
        A .ply point cloud of the skeleton (mesh input).
    progress : Progress, optional

    Returns
    -------
    dict
        ``kind`` of the input, ``voxels_changed`` (voxels added or removed on the pipeline's grid),
        and ``vertices`` and ``faces`` of a mesh output.
    """
    input_path, output_path = str(input_path), str(output_path)
    kind_in, kind_out = check_paths(input_path, output_path, save_skeleton)
    volume_params = volume_params or VolumeParams()
    progress = progress or Progress(enabled=False)
    if kind_in == "volume":
        return _denoise_volume_file(input_path, output_path, kind_out, params, volume_params, progress)
    mesh = io.load_mesh(input_path)
    io.check_precision(mesh, output_path)
    out, result, grid = pipeline.denoise_mesh_detailed(mesh, params, progress)
    if save_skeleton and not result.stages:
        raise InputError(f"--save-skeleton: no skeleton was computed ({progress.notes[-1]}); "
                         "--close runs the voxel stage")
    io.save_mesh(out, output_path, protect=[input_path])
    if save_skeleton:
        _save_skeleton(save_skeleton, result, grid, {input_path: "input", output_path: "output"})
    return {"kind": "mesh", "voxels_changed": result.voxels_changed, "vertices": len(out.vertices),
            "faces": len(out.faces)}


def _denoise_volume_file(input_path, output_path, kind_out, params, volume_params, progress):
    volume = volume_io.load_volume(input_path, volume_params.spacing)
    mask = volume_io.select_mask(volume.data, volume_params.label, volume_params.iso)
    result = pipeline.denoise_volume(mask, params, progress, spacing=volume.spacing)
    summary = {"kind": "volume", "voxels_changed": result.voxels_changed}
    if kind_out == "volume":
        data = (volume_io.merge_label(volume.data, mask, result.mask, volume_params.label)
                if volume_params.label is not None else result.mask)
        volume_io.save_volume(output_path, volume, data, protect=[input_path])
        return summary
    with progress.step("marching cubes"):
        mesh = surface.field_to_world_mesh(result.field, volume.affine)
    io.save_mesh(mesh, output_path, protect=[input_path])
    return {**summary, "vertices": len(mesh.vertices), "faces": len(mesh.faces)}


def _save_skeleton(path, result, grid, protect):
    """The skeleton voxels of every stage as a PLY point cloud with their measures."""
    points, props = [], {"quality": [], "d": [], "rho": [], "sigma_bar": [], "rho_plus": [], "kept": [],
                         "stage": []}
    for stage_id, name in enumerate(("foreground", "background")):
        if name not in result.stages:
            continue
        s = result.stages[name].skeleton
        ijk = np.stack(np.unravel_index(s.voxels, grid.shape), axis=1)
        points.append(grid.to_world(ijk))
        for key, values in (("quality", s.rho_plus), ("d", s.distance), ("rho", s.rho),
                            ("sigma_bar", s.sigma_bar), ("rho_plus", s.rho_plus), ("kept", s.kept)):
            props[key].append(values)
        props["stage"].append(np.full(len(s.voxels), stage_id))
    io.save_point_cloud_ply(path, np.concatenate(points), {k: np.concatenate(v) for k, v in props.items()},
                            protect)
