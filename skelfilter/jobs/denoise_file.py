"""One input file to one output file, whatever their kinds: the work of ``skelfilter denoise``, shared
with ``skelfilter batch``.

The kind of a file comes from its name: a volume (NIfTI, NRRD, TIFF, .npy; see
:mod:`skelfilter.io.volume_files`), a point cloud (PCD, XYZ, XYZN, PTS, or a PLY without faces; see
:mod:`skelfilter.mesh.point_cloud`), else a mesh (PLY, OBJ, STL, OFF, GLB). A mesh comes out as a mesh; a
volume as a volume (its format, grid, header and affine) or as a mesh in the scanner's world
coordinates; a point cloud as a closed mesh or as its points moved onto it. Every path is checked
before anything is read or computed.
"""


import numpy as np
import trimesh

from skelfilter.core import pipeline
from skelfilter.errors import InputError, OpenSurfaceError, ParameterError
from skelfilter.io import formats, mesh_files, output_files, ply_mesh, point_files, volume_files
from skelfilter.mesh import marching_cubes, point_cloud
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.params import DenoiseParams, VolumeParams
from skelfilter.runtime.progress import Progress

# What each kind of input can become.
OUTPUTS = {"mesh": ("mesh",), "volume": ("volume", "mesh"), "points": ("mesh", "points")}
# Mesh formats that hold named parts (every label of a label map).
PART_FORMATS = ("obj", "glb")


def check_paths(input_path, output_path, save_skeleton=None, points=False):
    """Refuse an impossible pair of paths before anything runs; returns (input kind, output kind).

    ``points``: a point cloud's output is its points moved onto the denoised surface (a PLY output
    would otherwise be the mesh).

    Raises
    ------
    InputError
        An unsupported format, an output the input cannot become, an output that is the input or
        sits in a missing folder, a skeleton file that is not a new .ply, or one asked of a volume.
    """
    kind_in, kind_out = formats.input_kind(input_path), formats.file_kind(output_path)
    if points or (kind_in == "points" and kind_out == "points"):
        if kind_in != "points" or formats.suffix(output_path) not in formats.POINT_FORMATS:
            raise InputError(f"{output_path}: moved points need a point cloud input and a point cloud output "
                             f"({', '.join(formats.POINT_FORMATS)})")
        kind_out = "points"
    if kind_out not in OUTPUTS[kind_in]:
        raise InputError(f"{output_path}: a {kind_in} input gives a {' or a '.join(OUTPUTS[kind_in])} output")
    output_files.check_output(output_path, [input_path])
    if save_skeleton:
        if kind_in != "mesh":
            raise InputError("`save_skeleton` needs a mesh input")
        output_files.check_output(save_skeleton, {input_path: "input", output_path: "output"}, ("ply",))
    return kind_in, kind_out


def denoise_file(input_path, output_path, params, volume_params=None, save_skeleton=None, progress=None,
                 points=False, preview=None):
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
    points : bool
        For a point cloud input: write its points moved onto the denoised surface, attributes kept,
        rather than the denoised mesh (see `check_paths`).
    preview : callable, optional
        Called with the input's surface and the output's (trimesh meshes in the same coordinates:
        a volume's and a point cloud's as marching cubes and Poisson surface) once the output is
        written; the CLI's ``--preview`` draws them side by side.

    Returns
    -------
    dict
        ``kind`` of the input, ``voxels_changed`` (voxels added or removed: on the grid a mesh is
        voxelized on, on a volume's own grid; None where the voxel stage did not run),
        and ``vertices``, ``faces`` and ``route`` (`skelfilter.mesh.route.Route.as_dict`: what ran and why)
        of a mesh output.
    """
    input_path, output_path = str(input_path), str(output_path)
    kind_in, kind_out = check_paths(input_path, output_path, save_skeleton, points)
    volume_params = volume_params or VolumeParams()
    if kind_in != "volume" and volume_params != VolumeParams():
        raise InputError(f"{input_path}: `label`, `iso` and `spacing` are for volume inputs")
    progress = progress or Progress(enabled=False)
    if kind_in == "volume":
        return _denoise_volume_file(input_path, output_path, kind_out, params, volume_params, progress, preview)
    if kind_in == "points":
        return _denoise_point_file(input_path, output_path, kind_out, params, progress, preview)
    mesh = mesh_files.load_mesh(input_path)
    mesh_files.check_mesh_output(mesh, output_path)
    out, result, grid = mesh_pipeline.denoise_mesh_detailed(mesh, params, progress)
    out.metadata.pop(mesh_pipeline.ROUTE_METADATA)  # the summary carries it; the file holds the mesh's own
    if out.units is None:  # a new closed mesh is in the input's unit
        out.units = mesh.units
    if "ply" in mesh.metadata:  # and a PLY output keeps the input's comments, naming what it drops
        out.metadata.setdefault("ply", mesh.metadata["ply"])
    if save_skeleton and not result.stages:
        raise InputError(f"`save_skeleton`: no skeleton was computed ({result.route.reason}); "
                         "`output_mesh` closed runs the voxel stage")
    mesh_files.save_mesh(out, output_path, protect=[input_path])
    if save_skeleton:
        _save_skeleton(save_skeleton, result, grid, {input_path: "input", output_path: "output"})
    if preview is not None:
        preview(mesh, out)
    return {"kind": "mesh", "voxels_changed": result.voxels_changed if result.stages else None,
            "vertices": len(out.vertices), "faces": len(out.faces), "route": result.route.as_dict()}


def _denoise_volume_file(input_path, output_path, kind_out, params, volume_params, progress, preview=None):
    if kind_out == "volume" and params.surface != DenoiseParams(preset=params.preset).surface:
        raise ParameterError(f"`surface` {params.surface} would have no effect: {output_path} is a volume, the "
                             "surface is made only for a mesh output")
    if volume_params.all_labels:
        return _denoise_label_map_file(input_path, output_path, kind_out, params, volume_params, progress, preview)
    volume = volume_files.load_volume(input_path, volume_params.spacing)
    mask = volume_files.select_mask(volume.data, volume_params.label, volume_params.iso)
    result = pipeline.denoise_volume(mask, params, progress, spacing=volume.spacing)
    if not result.mask.any():
        raise InputError(f"{input_path}: nothing is left after denoising (the shape is thinner than the "
                         "noise scale); lower `threshold`")
    summary = {"kind": "volume", "voxels_changed": result.voxels_changed}
    if kind_out == "volume":
        if volume_params.label is not None:
            data = volume_files.merge_label(volume.data, mask, result.mask, volume_params.label)
        elif volume_params.iso is None and volume.data.dtype != bool:  # a mask keeps its values (0/255 stays)
            data = volume_files.merge_label(volume.data, mask, result.mask, volume_files.set_value(volume.data, mask))
        else:
            data = result.mask
        volume_files.save_volume(output_path, volume, data, protect=[input_path])
        if preview is not None:
            _preview_volume(preview, mask, result, volume.affine, params, progress)
        return summary
    mesh = _volume_mesh(result, volume.affine, params, progress)
    mesh_files.save_mesh(mesh, output_path, protect=[input_path])
    if preview is not None:
        _preview_volume(preview, mask, result, volume.affine, params, progress, mesh)
    return {**summary, "vertices": len(mesh.vertices), "faces": len(mesh.faces)}


def _denoise_label_map_file(input_path, output_path, kind_out, params, volume_params, progress, preview=None):
    """Every label of a label map, each denoised on its own (`volume_files.merge_label` in turn); a mesh
    output is one named part per label (``label_N``), their surfaces sharing their boundaries
    (`marching_cubes.labels_to_world_meshes`)."""
    if kind_out == "mesh" and formats.suffix(output_path) not in PART_FORMATS:
        raise InputError(f"{output_path}: every label as a named part needs a {' or '.join(PART_FORMATS)} output")
    volume = volume_files.load_volume(input_path, volume_params.spacing)
    labels = volume_files.label_values(volume.data)
    data, changed = volume.data, 0
    for label in labels:
        with progress.stage(f"label {label}"):
            mask = volume.data == label
            result = pipeline.denoise_volume(mask, params, progress, spacing=volume.spacing)
        changed += result.voxels_changed
        data = volume_files.merge_label(data, mask, result.mask, label)
    summary = {"kind": "volume", "voxels_changed": changed}
    if kind_out == "volume":
        volume_files.save_volume(output_path, volume, data, protect=[input_path])
        return summary
    with progress.step("smooth surfaces"):
        meshes = marching_cubes.labels_to_world_meshes(data, volume.affine,
                                                       [v for v in labels if (data == v).any()])
    mesh_files.save_parts({f"label_{label}": mesh for label, mesh in meshes.items()}, output_path,
                          protect=[input_path])
    if preview is not None:
        before = marching_cubes.mask_to_world_mesh(volume.data != 0, volume.affine, smooth=False)
        preview(before, trimesh.util.concatenate(list(meshes.values())))
    return {**summary, "vertices": sum(len(m.vertices) for m in meshes.values()),
            "faces": sum(len(m.faces) for m in meshes.values())}


def _volume_mesh(result, affine, params, progress):
    """The mesh of a denoised volume in world coordinates: with the surface 'smooth', the smooth surface
    its voxels sample (`marching_cubes.mask_to_world_mesh`), else the marching cubes of its field."""
    if params.surface == "plain":
        with progress.step("marching cubes"):
            return marching_cubes.field_to_world_mesh(result.field, affine)
    with progress.step("smooth surface"):
        return marching_cubes.mask_to_world_mesh(result.mask, affine)


def _preview_volume(preview, mask, result, affine, params, progress, output_mesh=None):
    """``preview`` of a volume: the input's voxels (their plain marching cubes) and the output's surface."""
    with progress.step("preview surfaces"):
        before = marching_cubes.mask_to_world_mesh(mask, affine, smooth=False)
    after = output_mesh if output_mesh is not None else _volume_mesh(result, affine, params, progress)
    preview(before, after)


def _denoise_point_file(input_path, output_path, kind_out, params, progress, preview=None):
    """A point cloud: its Poisson solid, denoised to a new closed mesh (there is no input mesh to
    keep), written as a mesh or as the points moved onto it."""
    cloud = point_files.load_points(input_path)
    with progress.step("Poisson surface"):
        solid = point_cloud.points_to_mesh(cloud, input_path)
    try:
        out, result, _ = mesh_pipeline.denoise_mesh_detailed(solid, params.with_(output_mesh="closed"), progress)
        out.metadata.pop(mesh_pipeline.ROUTE_METADATA)
    except OpenSurfaceError:
        raise InputError(f"{input_path}: the points' Poisson surface encloses no solid (a scan that does not go "
                         "all round the object, or noise as thick as its thinnest parts)") from None
    summary = {"kind": "points", "voxels_changed": result.voxels_changed}
    if kind_out == "points":
        with progress.step("points moved"):
            point_files.save_points(point_cloud.move_points(cloud, out), output_path, protect=[input_path])
    else:
        mesh_files.save_mesh(out, output_path, protect=[input_path])
    if preview is not None:
        preview(solid, out)
    if kind_out == "points":
        return summary
    return {**summary, "vertices": len(out.vertices), "faces": len(out.faces)}


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
    ply_mesh.save_point_cloud_ply(path, np.concatenate(points), {k: np.concatenate(v) for k, v in props.items()},
                                  protect)
