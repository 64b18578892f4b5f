"""The pipeline on triangle meshes: voxelize, the volume pipeline (:mod:`skelfilter.core.pipeline`), and
back to a mesh: a new closed one by marching cubes, or the input's own with its vertices moved."""

import warnings

import numpy as np
import trimesh

from skelfilter.core import surface_field, synthetic_noise
from skelfilter.core.decision.stage_pruning import passes_through
from skelfilter.core.pipeline import DenoiseResult, denoise_padded, padding_from, resolve_params
from skelfilter.errors import InputError, OpenSurfaceError, ParameterError, ResourceError
from skelfilter.io.mesh_files import validate_mesh
from skelfilter.mesh import fine_pass, marching_cubes, route, vertex_projection, voxelize
from skelfilter.mesh.frame import Frame
from skelfilter.mesh.welding import weld
from skelfilter.parameter_fields import build, with_parameter_entries
from skelfilter.params import DenoiseParams, NoiseParams, voxel_fields_given
from skelfilter.runtime import worker_threads
from skelfilter.runtime.memory import check_grid_fits
from skelfilter.runtime.progress import Progress

# The key of the output mesh's ``metadata`` that holds its `route.Route` (`Route.as_dict`).
ROUTE_METADATA = "skelfilter"


def _voxelize(mesh, resolution, padding, progress, padding_by, required=True, lattice=None):
    """Occupancy of a mesh on its padded grid, memory checked before allocating (``padding_by``: the
    parameters that set the padding, for the advice). An empty occupancy is refused if ``required``.
    The grid is ``lattice``'s (`voxelize.voxel_lattice`) where given."""
    grid = _grid(mesh, resolution, padding, lattice)
    check_grid_fits(grid.shape, padding=padding, padding_from=padding_by, faces=len(mesh.faces))
    with progress.step("voxelize"):
        occupancy = voxelize.voxelize_on_grid(mesh, grid)
    if required:
        _require_inside(occupancy, mesh, grid, resolution)
    return occupancy, grid


def _grid(mesh, resolution, padding, lattice=None):
    """The padded grid of ``mesh``: ``resolution`` voxels along its longest side, or the voxel
    ``lattice`` it was made on (`voxelize.voxel_lattice`)."""
    if lattice is not None:
        return voxelize.grid_on_lattice(mesh.bounds, *lattice, padding)
    return voxelize.grid_for_bounds(mesh.bounds, resolution, padding)


def _require_inside(occupancy, mesh, grid, resolution):
    if not occupancy.any():
        raise InputError(f"the mesh encloses no voxel at resolution {resolution}: {voxelize.why_empty(mesh, grid)}")


def denoise_mesh(mesh, params=None, progress=None, **overrides):
    """Denoise a triangle mesh, on the route its roughness calls for (`route.choose`).

    A clean mesh comes back as it was; fine noise is smoothed on the input mesh itself (the fine pass);
    a solid covered in noise at the skeleton's scale goes through the skeleton denoiser on its voxels
    (thesis §8.1.1) and comes back as a new closed mesh where noise was pruned.

    Parameters
    ----------
    mesh : trimesh.Trimesh or (vertices, faces)
    params : DenoiseParams, optional
        The parameters; the keywords below override its fields (a field left unset takes the preset's).
    progress : Progress, optional
        Step timings and the notes that say what was chosen (printed when enabled).

    Returns
    -------
    trimesh.Trimesh
        In the input's world coordinates: the input mesh with its vertices moved or as it was (an open
        surface stays open; colours and UVs kept), or a new closed mesh. Its ``metadata["skelfilter"]``
        says which route ran and why, with the roughness and the noise measured (`route.Route.as_dict`).

    Examples
    --------
    >>> import trimesh
    >>> from skelfilter import denoise_mesh
    >>> out = denoise_mesh(trimesh.creation.icosphere(subdivisions=3))
    >>> out.metadata["skelfilter"]["route"]
    'as it was'

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §8.1.1.
    .. [2] A. Telea, "Feature preserving smoothing of shapes using saliency skeletons",
           Visualization in Medicine and Life Sciences II, Springer, 2012.
    """
    return denoise_mesh_detailed(mesh, params, progress, **overrides)[0]


with_parameter_entries(denoise_mesh, DenoiseParams)


def denoise_mesh_detailed(mesh, params=None, progress=None, **overrides):
    """Like :func:`denoise_mesh`, also returning the DenoiseResult and the Grid.

    The DenoiseResult's ``route`` (`route.Route`) says which route the mesh took and why, with the
    roughness and noise measured; it has no stages when the voxel stage did not run.
    The work is done in the mesh's unit frame (:mod:`skelfilter.mesh.frame`): the result does not
    depend on the mesh's scale or position.
    """
    params = resolve_params(params, **overrides)
    progress = progress or Progress(enabled=False)
    mesh = validate_mesh(mesh)
    frame = Frame.of(mesh)
    unit = frame.to_unit(mesh)
    try:
        closed, kept_vertices, result, grid = _denoise_unit(unit, params, progress)
    except MemoryError:
        raise ResourceError(f"out of memory denoising a mesh of {len(mesh.faces)} faces; lower `resolution`, "
                            "simplify the mesh, or free memory") from None
    lost = _attributes(mesh) if closed is not None and params.output_mesh == "auto" else ""
    if lost:
        warnings.warn(f"the new closed mesh has no {lost}; output_mesh input keeps them "
                      "(the input mesh with its vertices moved)", stacklevel=2)
    out = frame.to_world(closed) if closed is not None else frame.moved(mesh, unit, kept_vertices)
    out.metadata[ROUTE_METADATA] = result.route.as_dict()
    return out, result, frame.grid_to_world(grid)


def _denoise_unit(mesh, params, progress):
    """`denoise_mesh_detailed` on a mesh in its unit frame: (a new closed mesh or None, the moved
    vertices of ``mesh`` or None, the DenoiseResult with its `route.Route`, the Grid)."""
    given = voxel_fields_given(params)
    asked = [name for name in given if name != "resolution"]  # the resolution also tells solids from surfaces
    if params.resolution is not None:  # a grid that cannot be is refused whatever runs
        check_grid_fits(_grid(mesh, params.resolution, params.padding_voxels).shape, padding=params.padding_voxels,
                        padding_from=padding_from(params), faces=len(mesh.faces))
    lattice = voxelize.voxel_lattice(mesh)
    chosen = route.choose(mesh, params, lattice, bool(asked), progress)
    if chosen.kind == route.AS_IT_WAS:
        return _as_it_was(mesh, params, chosen, given, progress)
    smoothed_first = False
    if chosen.output == "closed" and chosen.roughness is not None and (
            params.fine_pass == "on" or (params.fine_pass == "auto" and chosen.roughness.noisy
                                         and not chosen.roughness.skeleton_scale)):
        mesh, smoothed_first = _smoothed_first(mesh, params, chosen.roughness, progress), True
    worker_threads.start()
    if chosen.kind == route.FINE_PASS:
        params, _ = _resolved(mesh, params, lattice, True, progress)
        grid = _grid(mesh, params.resolution, params.padding_voxels)
        unused = f" (resolution {params.resolution} is not used)" if given else ""
        return _fine_pass_only(mesh, params, chosen.settled(reason=chosen.reason + unused), grid, progress)
    return _voxel_stage(mesh, params, chosen.settled(fine_pass=smoothed_first), lattice, given, asked, progress)


def _voxel_stage(mesh, params, chosen, lattice, given, asked, progress):
    """`_denoise_unit`'s voxel stage route: the solid check, the skeleton denoiser, then a new closed mesh
    or the input's vertices moved; a surface that is not a solid goes to `_fine_pass_only`."""
    routed = chosen.roughness is not None and params.output_mesh == "auto" and not asked
    if routed:
        progress.note(chosen.reason)
    preferred = route.SKELETON_RESOLUTION if routed else None
    params, lattice = _resolved(mesh, params, lattice, False, progress, preferred)
    output = params.output_mesh
    occupancy, grid = _voxelize(mesh, params.resolution, params.padding_voxels, progress, padding_from(params),
                                required=output == "closed", lattice=lattice)
    with progress.step("solid check"):
        solid = occupancy.any() and (
            route.is_closed(mesh.faces)
            or route.solid_share(occupancy, mesh, grid) >= route.SOLID_SHARE)
    if not solid:
        if output == "closed":
            raise OpenSurfaceError(
                f"the input is an open surface (less than {100 * route.SOLID_SHARE:g} % of its "
                "voxelization lies on it): a new closed mesh of it would be the voxels it happens to enclose, "
                "not the scan; output_mesh auto or input keeps the surface and smooths it")
        why = (f"the input is an open surface: its own mesh comes back, {route.fine_pass_effect(params)} "
               "(the voxel stage needs a solid)")
        if given:
            why += f" (resolution {params.resolution} was used only to tell a solid from a surface)"
        if asked:
            raise ParameterError(f"{', '.join(asked)} would have no effect: {why}; output_mesh closed runs "
                                 "the voxel stage on any input")
        return _fine_pass_only(mesh, params, chosen.settled(kind=route.FINE_PASS, reason=why, output="input"),
                               grid, progress, occupancy)
    _require_inside(occupancy, mesh, grid, params.resolution)
    result = denoise_padded(occupancy.copy(), params, progress)
    result.voxels_changed = int(np.count_nonzero(result.mask != occupancy))
    voxel_moves = output == "input"
    why = chosen.reason
    if output == "auto":
        output, why = _auto_output(params, result, chosen.roughness, progress)
    result.route = chosen.settled(output=output, reason=why, noise=dict(result.noise), dents=result.dents)
    if output == "closed":
        kept = None
        if params.unchanged_surface == "input":
            with progress.step("input surface"):
                kept = marching_cubes.keep_input_surface(result.field, result.mask, occupancy, mesh, grid)
        del occupancy
        if params.surface == "plain":
            with progress.step("marching cubes"):
                return marching_cubes.field_to_mesh(result.field, grid), None, result, grid
        with progress.step("smooth surface"):
            return marching_cubes.smooth_field_to_mesh(result.field, result.mask, grid, kept), None, result, grid
    vertices, smoothed = _kept_vertices(mesh, (result, occupancy) if voxel_moves else None, params, grid, progress,
                                        chosen.roughness)
    result.route = result.route.settled(fine_pass=smoothed)
    return None, vertices, result, grid


def _auto_output(params, result, roughness, progress):
    """``output_mesh`` auto after the voxel stage: ``("closed" or "input", why)``, told through ``progress``.
    A new closed mesh where the stages pruned noise at the skeleton's scale (on a mesh not made of
    voxels, on at least `route.SKELETON_COVERAGE` of the surface), else the input mesh."""
    pruned = not passes_through(params, result) and result.voxels_changed
    found = result.noise.get("foreground")
    if pruned and roughness is not None and found is not None and found.coverage < route.SKELETON_COVERAGE:
        pruned = False  # too little for noise at the skeleton's scale on a mesh not made of voxels
        progress.note(f"noise at the skeleton's scale on {100 * found.coverage:.0f} % of the surface (from "
                      f"{100 * route.SKELETON_COVERAGE:.0f} % on a mesh not made of voxels): not pruned")
    output = "closed" if pruned else "input"
    if output == "input":
        why = "no noise at the skeleton scale"
    elif found is not None and not found.found:
        why = f"pruned as told at t = {params.threshold_voxels:g} voxels (prune as-told), though no noise was found"
    else:
        why = "noise at the skeleton scale removed"
    progress.note(f"output: {'a new closed mesh' if output == 'closed' else 'the input mesh'} ({why})")
    return output, why


def _fine_pass_only(mesh, params, chosen, grid, progress, occupancy=None):
    """`_denoise_unit`'s fine pass route: the voxel stage does not run (``occupancy``: the input's
    voxels where it was voxelized to tell a solid from a surface); the input's vertices, smoothed where
    the fine pass runs."""
    progress.note(chosen.reason)
    result = DenoiseResult(mask=occupancy, field=None, timings=progress.timings)
    vertices, smoothed = _kept_vertices(mesh, None, params, grid, progress, chosen.roughness)
    result.route = chosen.settled(fine_pass=smoothed)
    return None, vertices, result, grid


def _smoothed_first(mesh, params, roughness, progress):
    """``mesh`` smoothed by the fine pass before it is voxelized for a new closed mesh, where its noise is
    fine (what the default's routing gives the fine pass) or the fine pass is on: the closed mesh keeps
    the input's own surface wherever the voxel stage changes nothing (`marching_cubes.keep_input_surface`),
    so fine noise left on the input would stay on it."""
    progress.note(f"{roughness.describe()}: smoothed by the fine pass before the voxel stage")
    vertices, _ = _kept_vertices(mesh, None, params.with_(fine_pass="on"), None, progress, roughness)
    return trimesh.Trimesh(vertices, np.asarray(mesh.faces), process=False)


def _as_it_was(mesh, params, chosen, given, progress):
    """`_denoise_unit`'s answer for a clean mesh: its own vertices, no voxel stage."""
    unused = f" (resolution {params.resolution} is not used)" if given else ""
    progress.note(f"{chosen.reason}{unused} (--fine-pass on smooths it anyway, --output-mesh closed runs the voxel "
                  "stage)")
    resolution = params.resolution or voxelize.auto_resolution(mesh)
    grid = _grid(mesh, resolution, params.with_(resolution=resolution).padding_voxels)
    result = DenoiseResult(None, None, timings=progress.timings)
    result.route = chosen.settled(reason=chosen.reason + unused)
    return None, np.array(mesh.vertices, dtype=np.float64), result, grid


def _resolved(mesh, params, lattice, skipped, progress, preferred=None):
    """``params`` with its resolution set, and the voxel ``lattice`` to lay the grid on (or None).

    Unset, the resolution fits the mesh (`_fitting_resolution`, from ``preferred`` where given), or,
    where the voxel stage is ``skipped``, is `voxelize.auto_resolution` (the frame of the empty result
    only)."""
    if params.resolution is not None:
        return params, None
    if skipped:
        return params.with_(resolution=voxelize.auto_resolution(mesh)), None
    resolution, lattice = _fitting_resolution(mesh, params, lattice, preferred)
    why = ("the voxel grid its surface was made on, by marching cubes" if lattice else
           "the voxel stage's own" if preferred else "from the mesh's mean edge length")
    progress.note(f"resolution {resolution} voxels ({why})")
    return params.with_(resolution=resolution), lattice


def _attributes(mesh):
    """The per-vertex or per-face attributes of ``mesh`` that a new mesh cannot carry, in words."""
    kind = getattr(mesh.visual, "kind", None)
    return {"vertex": "vertex colours", "face": "face colours", "texture": "texture coordinates"}.get(kind, "")


def _kept_vertices(mesh, voxels, params, grid, progress, roughness=None):
    """The input mesh's vertices, moved: onto the denoised surface where ``voxels`` (the
    DenoiseResult and the input occupancy, or None) says the shape changed, then by the fine pass;
    and whether the fine pass ran.

    The fine pass runs with ``fine_pass`` on; with ``auto``, where vertices moved or the mesh is
    `_noisy` (``roughness``: its `route.Roughness`, or None for a voxel mesh).
    """
    # Vertices split along UV seams or by the file format move as one.
    welded, inverse = weld(mesh.vertices)
    faces = inverse[np.asarray(mesh.faces, dtype=np.int64)]
    vertices, moved = welded, np.zeros(len(welded), dtype=bool)
    if voxels is not None:
        result, occupancy = voxels
        with progress.step("vertices moved"):
            vertices, moved = vertex_projection.move_input_vertices(
                welded, faces, result.mask, occupancy, result.field, surface_field.mask_field(occupancy), grid,
                max_move=params.threshold_voxels / 2)
    least_level = route.LEAST_FINE_LEVEL if roughness is not None and roughness.noisy else 0.0
    smoothing = params.fine_pass == "on" or (
        params.fine_pass == "auto" and (moved.any() or _noisy(welded, faces, roughness, progress)))
    if smoothing:
        with progress.step("fine pass"):
            # The rim of an open surface stays where it was (measured on Nicolo0.2: both scores
            # lower than with the rim smoothed, and the boundary exactly the input's).
            rim = vertex_projection.boundary_vertices(faces, len(vertices))
            smoothed, reference = fine_pass.fine_pass(vertices, faces, movable=~rim,
                                                      normal_filter=params.normal_filter, least_level=least_level)
            # Faces keep the filtered normals' orientation, or the denoised surface's where
            # vertices moved onto it.
            near_moved = moved[faces].any(axis=1)
            if near_moved.any():
                reference[near_moved] = vertex_projection.outward_normals(
                    grid.to_index(vertices[faces[near_moved]].mean(axis=1)), voxels[0].field)
            vertices, folded = vertex_projection.unfold(smoothed, faces, reference)
        if folded:
            progress.note(f"{folded} {'face stays' if folded == 1 else 'faces stay'} folded (turned against the "
                          "surface or without area, where noise folded the surface over itself; they may show as "
                          "dark specks): --output-mesh closed makes a new closed mesh from the voxels instead")
    return vertices[inverse], bool(smoothing)


def _noisy(vertices, faces, roughness, progress):
    """Whether a mesh is noisy: by its ``roughness`` where measured, else (a voxel mesh) by its
    `route.sampled_normal_roughness` (told through ``progress`` where it is clean)."""
    if roughness is not None:
        return roughness.noisy
    with progress.step("fine noise"):
        fine = route.sampled_normal_roughness(trimesh.Trimesh(vertices, faces, process=False))
    if fine < route.CLEAN_FINE_NOISE:
        progress.note(f"fine noise: each face turns {_degrees(fine):.1f}° from its most parallel neighbour "
                      f"(median; noise from {_degrees(route.CLEAN_FINE_NOISE):.1f}°): no fine pass, "
                      "the mesh comes back as it was (--fine-pass on smooths it anyway)")
    return fine >= route.CLEAN_FINE_NOISE


def _degrees(normal_difference):
    """The angle between unit normals ``normal_difference`` apart (`normal_filtering.normal_roughness`)."""
    return float(np.degrees(2 * np.arcsin(min(normal_difference / 2, 1.0))))


def _fitting_resolution(mesh, params, lattice, preferred=None):
    """The resolution for ``mesh`` and the voxel ``lattice`` it was made on (`voxelize.voxel_lattice`)
    to lay its grid on, or None.

    A voxel mesh (`voxelize.voxel_lattice`: marching cubes of a volume) is denoised on the grid it
    was made on, up to `voxelize.AUTO_RESOLUTION_RANGE`'s top: its noise is made of those voxels,
    and on that grid the voxelization gives them back; a finer grid costs time and finds nothing
    more. Otherwise ``preferred``, or `voxelize.auto_resolution`. Either is lowered until the grid
    fits in memory (at least 16), and the lattice is then not used.
    """
    if lattice is not None:
        resolution = int(round(float(np.ptp(np.asarray(mesh.bounds), axis=0).max()) / lattice[0]))
        if 16 <= resolution <= voxelize.AUTO_RESOLUTION_RANGE[1] and _fits(mesh, params, resolution, lattice):
            return resolution, lattice
    resolution = preferred or voxelize.auto_resolution(mesh)
    while resolution > 16 and not _fits(mesh, params, resolution):
        resolution = max(16, int(resolution * 0.9))
    _fits(mesh, params, resolution, refuse=True)
    return resolution, None


def _fits(mesh, params, resolution, lattice=None, refuse=False):
    """Whether ``mesh``'s grid at ``resolution`` (or on ``lattice``) fits in memory; if not and
    ``refuse``, the ResourceError says why."""
    shape = _grid(mesh, resolution, params.with_(resolution=resolution).padding_voxels, lattice).shape
    try:
        check_grid_fits(shape, faces=len(mesh.faces))
    except ResourceError:
        if refuse:
            raise
        return False
    return True


def noisy_mesh(mesh, params=None, progress=None, **overrides):
    """The thesis' synthetic noise (§7.2) on a mesh's voxelization.

    Returns
    -------
    (trimesh.Trimesh, noise.NoiseResult, voxelize.Grid)
        The noisy mesh in world coordinates; the clean/noisy/bump/dent masks
        over the grid, for metrics.

    References
    ----------
    .. [1] H. R. Schubert, "Salient edge preserving noise removal using surface skeletons", master
           thesis, University of Groningen, 2016, §7.2.
    """
    params = build(NoiseParams, params, **overrides)
    progress = progress or Progress(enabled=False)
    mesh = validate_mesh(mesh)
    worker_threads.start()
    frame = Frame.of(mesh)
    clean, grid = _voxelize(frame.to_unit(mesh), params.resolution, params.padding_voxels, progress,
                            "`h` and `r` (the padding is h + r + 10)")
    with progress.step("noise"):
        result = synthetic_noise.add_noise(clean, p=params.p, r=params.r, h=params.h, l=params.l,
                                 seed=params.seed, dents=params.dents)
    with progress.step("marching cubes"):
        out = marching_cubes.mask_to_mesh(result.noisy, grid)
    return frame.to_world(out), result, frame.grid_to_world(grid)
