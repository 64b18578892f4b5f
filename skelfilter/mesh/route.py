"""The route a mesh takes through the pipeline: decided in one place (`choose`), carried out by
:mod:`skelfilter.mesh.pipeline`, and handed to the caller with the output (`Route`).

Three routes (`ROUTES`):

- ``as it was``: a clean mesh (`Roughness` finds no noise) comes back unchanged, nothing
  voxelized;
- ``fine pass``: the voxel stage does not run (the noise is finer than the skeleton's scale, or the
  input is an open surface): the input mesh comes back, its vertices smoothed by the fine pass where it
  is noisy (`skelfilter.mesh.fine_pass`);
- ``voxel stage``: the skeleton denoiser runs on the mesh's voxels; the output is a new closed mesh
  (``closed``) or the input mesh with its vertices moved (``input``).

`choose` decides what can be decided before voxelizing, from the input's roughness
(`measure`) and the parameters; the voxel stage settles the rest (a surface that is not a
solid goes to the fine pass; ``output_mesh`` auto becomes closed where noise at the skeleton's scale was
pruned), and `Route.settled` records it.

How the roughness decides, and the measures the voxel stage's route uses:

The route of a mesh that was not made of voxels is decided by its `surface_roughness`,
which depends neither on how the file stores the vertices nor on the tessellation:

- under `CLEAN_ROUGHNESS` degrees the mesh is clean and comes back as it was, before anything is
  voxelized (clean meshes of every kind measure 0-4.2°, the noisy ones from 6.2°);
- rougher, but its faces turn with the shape: a low-poly model (an ant's six-sided legs, a modelled cow)
  turns its normals at every face as noise does, yet its vertices lean like their neighbours (the
  shape's curvature) where vertex noise and a depth camera's push them apart. Where the neighbours'
  offsets correlate from `SHAPE_CORRELATION` (`normal_filtering.noise_correlation`) and the roughness
  is not at the skeleton's scale, the mesh is clean too;
- noisy, with a `coarse_roughness` under `SKELETON_ROUGHNESS` degrees: the noise is below the
  skeleton's scale (vertex noise, a depth camera's, spikes), and the fine pass smooths the input mesh;
- noisy at a coarser scale too, and a solid: the voxel stage measures the noise at the skeleton's
  scale; it prunes where that noise covers at least `SKELETON_COVERAGE` of the surface, and the fine
  pass smooths the input mesh otherwise.

Measured on the labelled corpus of ``benchmarks/routing.py`` (``docs/routing.md``). A voxel mesh
(marching cubes of a volume: its faces are the voxels' stair steps, rough by construction) goes to the
voxel stage, which tells its noise from its steps. Further measurements:

- `is_closed`, `solid_share`: is the input a solid? A closed mesh is. Otherwise its voxelization
  fills whatever it encloses; when that closes only small holes (the bunny's base), nearly all of
  the voxel surface lies on the input mesh, while an open surface (a relief, a single-view scan)
  gets a cap that lies far from it. Only a solid goes to the voxel stage.
- `sampled_normal_roughness` of a voxel mesh: whether its faces turn away from all their neighbours. Voxel meshes
  have a flat neighbour for every face; where the voxel stage moved none of its vertices and it
  measures under `CLEAN_FINE_NOISE` it comes back as it was.
"""

from dataclasses import dataclass, field, replace

import numpy as np

from skelfilter.core.neighbourhood import surface_voxels
from skelfilter.mesh import normal_filtering, surface_roughness
from skelfilter.mesh.closest_points import within
from skelfilter.mesh.welding import weld

# Voxels of the input's voxel surface that must lie within `NEAR` voxels of the input mesh for the
# input to count as a solid.
SOLID_SHARE = 0.98
NEAR = 2.0
# Under this fine noise a voxel mesh has none: where the voxel stage changed nothing it comes back as it
# was, without the fine pass.
CLEAN_FINE_NOISE = 0.06
# Faces, or voxels, on which the shares above are measured at most (a random sample, fixed seed).
SAMPLE = 50_000
# Degrees of `surface_roughness.roughness` from which a mesh carries noise: clean meshes of the
# routing corpus measure at most 4.2 (a finely tessellated scan, the Stanford bunny), noisy ones from
# 6.2 (a depth camera's scan of fandisk).
CLEAN_ROUGHNESS = 5.0
# Moran's I of the vertices' offsets from their neighbours (`normal_filtering.noise_correlation`) from
# which a mesh rougher than `CLEAN_ROUGHNESS` at the fine scale only is a clean model whose faces turn
# with its shape. On the routing corpus (tuning split) the noisy meshes under `SKELETON_ROUGHNESS`
# measure -0.15 to 0.08 (vertex noise and spikes below 0, a depth camera's waves and terraces 0.01-0.08)
# and the low-poly insects 0.34-0.39; bumps at the skeleton's scale lift whole patches alike (0.15-0.36)
# and are told by their coarse roughness instead. Gaussian noise of 0.2 mean edge lengths on a low-poly
# mesh whose faces turn as sharply as its noise turns them (an insect's six-sided legs) still reads
# 0.3: such light noise on such a mesh is left, rather than a clean low-poly model smoothed.
SHAPE_CORRELATION = 0.2
# Degrees of `surface_roughness.coarse_roughness` from which the noise may stand at the skeleton's
# scale: between the finer noises' highest and the thesis' bumps' lowest (docs/design/decisions.md).
SKELETON_ROUGHNESS = 14.0
# The share of the surface that the voxel stage's noise estimate must find covered for a mesh that was
# not made of voxels to be pruned: vertex noise run through the voxel stage covers less, bumps at the
# skeleton's scale more (the margin is thin; docs/design/decisions.md).
SKELETON_COVERAGE = 0.08
# The resolution (voxels along the longest side) of the voxel stage on a mesh sent there by its roughness,
# unless given: the one the default's voxel-stage parameters were chosen at (t is 30 voxels, peaks count
# from 3), which the noise's scale, not the mesh's edge length, calls for.
SKELETON_RESOLUTION = 160
# The fine pass on a noisy mesh smooths at least as at this `normal_filtering.normal_roughness` (the least
# the literature's noisy pairs measure is 0.115): the noise level of meshes whose faces come in flat
# pairs (depth cameras' terraces, quads split in two) reads near 0 though they carry noise.
LEAST_FINE_LEVEL = 0.11


@dataclass(frozen=True)
class Roughness:
    """What `measure` found on a mesh, in degrees (`skelfilter.mesh.surface_roughness`)."""

    fine: float
    coarse: float | None  # measured only where the fine roughness finds noise
    correlation: float | None = None  # measured only where the noise would be under the skeleton's scale

    @property
    def noisy(self):
        return self.fine >= CLEAN_ROUGHNESS and not self.shaped

    @property
    def shaped(self):
        """Rough at the fine scale only, with the vertices leaning like their neighbours: a low-poly model."""
        return self.correlation is not None and self.correlation >= SHAPE_CORRELATION

    @property
    def skeleton_scale(self):
        return self.noisy and self.coarse >= SKELETON_ROUGHNESS

    def describe(self):
        """One line a user can read."""
        if self.shaped:
            return (f"surface roughness {self.fine:.1f}°, its faces turning with the shape (neighbouring vertices "
                    f"lean alike: {self.correlation:.2f}, noise under {SHAPE_CORRELATION:g}): clean")
        if not self.noisy:
            return f"surface roughness {self.fine:.1f}° (clean under {CLEAN_ROUGHNESS:g}°)"
        scale = (f"{self.coarse:.1f}° over wider patches (from {SKELETON_ROUGHNESS:g}°: noise at the skeleton's "
                 "scale possible)" if self.skeleton_scale else
                 f"{self.coarse:.1f}° over wider patches (under {SKELETON_ROUGHNESS:g}°: fine noise)")
        return f"surface roughness {self.fine:.1f}° (noisy from {CLEAN_ROUGHNESS:g}°), {scale}"


def measure(mesh):
    """The `Roughness` of a mesh."""
    points, normals = surface_roughness.surface_samples(mesh.vertices, mesh.faces)
    fine = surface_roughness.roughness(points, normals)
    if fine < CLEAN_ROUGHNESS:
        return Roughness(fine, None)
    coarse = surface_roughness.coarse_roughness(points, normals, len(mesh.faces))
    if coarse >= SKELETON_ROUGHNESS:
        return Roughness(fine, coarse)
    # on the vertices as they meet (an STL file stores every triangle's corners apart)
    welded, inverse = weld(mesh.vertices)
    faces = inverse.reshape(-1)[np.asarray(mesh.faces, dtype=np.int64)]
    return Roughness(fine, coarse, normal_filtering.noise_correlation(welded, faces))


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


def sampled_normal_roughness(mesh, sample=SAMPLE, seed=0):
    """`skelfilter.mesh.normal_filtering.normal_roughness` of a mesh, on at most ``sample`` of its faces."""
    faces = np.asarray(mesh.faces, dtype=np.int64)
    normals = normal_filtering.face_normals(np.asarray(mesh.vertices, dtype=np.float64), faces)
    subset = None
    if len(faces) > sample:
        subset = np.sort(np.random.default_rng(seed).choice(len(faces), sample, replace=False))
    pairs = normal_filtering.face_neighbours(faces, len(mesh.vertices), subset)
    return normal_filtering.normal_roughness(normals, pairs)


AS_IT_WAS, FINE_PASS, VOXEL_STAGE = "as it was", "fine pass", "voxel stage"
ROUTES = (AS_IT_WAS, FINE_PASS, VOXEL_STAGE)


@dataclass(frozen=True)
class Route:
    """What the mesh pipeline did with a mesh, and why.

    On `DenoiseResult.route` and, as `as_dict`, on the output mesh's ``metadata["skelfilter"]``.

    Attributes
    ----------
    kind : str
        One of `ROUTES`.
    reason : str
        Why, in one line a user can read (the CLI prints it).
    output : str
        ``"input"``: the input mesh, its vertices moved or not; ``"closed"``: a new closed mesh.
    roughness : Roughness or None
        The input's surface roughness, where it was measured (not on a voxel mesh, which goes to the
        voxel stage).
    noise : dict
        ``"foreground"`` / ``"background"`` -> `skelfilter.core.decision.noise_estimate.NoiseEstimate`, the
        noise each stage measured, where the voxel stage ran.
    fine_pass : bool
        Whether the fine pass smoothed the output's vertices (before voxelizing, for a closed output).
    dents : DentReading or None
        `skelfilter.core.decision.two_sided.DentReading`: whether the voxel stage read dents on the
        input and decided both sides (``stages`` auto).
    """

    kind: str
    reason: str
    output: str = "input"
    roughness: Roughness | None = None
    noise: dict = field(default_factory=dict)
    fine_pass: bool = False
    dents: object = None

    def settled(self, **changes):
        """This route with what the later steps found (`dataclasses.replace`)."""
        return replace(self, **changes)

    def describe(self):
        """One line, e.g. ``fine pass, the input mesh: surface roughness 19.7° (...)``."""
        output = "a new closed mesh" if self.output == "closed" else "the input mesh"
        return f"{self.kind}, {output}: {self.reason}"

    def as_dict(self):
        """The route in plain values (strings, numbers, booleans, dicts): for a mesh's metadata or JSON."""
        roughness = None
        if self.roughness is not None:
            roughness = {"fine_degrees": self.roughness.fine, "coarse_degrees": self.roughness.coarse,
                         "correlation": self.roughness.correlation}
        noise = {side: {"found": bool(e.found), "height_voxels": float(e.height), "coverage": float(e.coverage)}
                 for side, e in self.noise.items()}
        dents = None
        if self.dents is not None:
            dents = {"pitted_depth_voxels": self.dents.depth, "found": self.dents.found,
                     "voxels_changed": self.dents.changed}
        return {"route": self.kind, "output": self.output, "reason": self.reason, "fine_pass": self.fine_pass,
                "roughness": roughness, "noise": noise, "dents": dents}


def choose(mesh, params, lattice, asked, progress):
    """The route of ``mesh`` (in its unit frame) as far as it is decided before voxelizing.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    params : DenoiseParams
    lattice : tuple or None
        The voxel lattice the mesh was made on (`voxelize.voxel_lattice`): a voxel mesh goes to the voxel
        stage, which tells its noise from its steps.
    asked : bool
        Whether the caller set a field of the voxel stage (other than the resolution): the voxel stage
        then runs whatever the roughness.
    progress : Progress
        Times the roughness step.

    Returns
    -------
    Route
        ``as it was`` or ``fine pass`` where ``output_mesh`` is auto and the roughness says so, else
        ``voxel stage`` with the output asked for (auto until the voxel stage settles it).
    """
    roughness = None
    if lattice is None and (params.output_mesh in ("auto", "input") or params.fine_pass != "off"):
        with progress.step("roughness"):
            roughness = measure(mesh)
    routed = params.output_mesh == "auto" and not asked and roughness is not None
    if routed and not roughness.noisy and params.fine_pass != "on":
        return Route(AS_IT_WAS, f"{roughness.describe()}: the mesh comes back as it was", roughness=roughness)
    if routed and not roughness.skeleton_scale:
        return Route(FINE_PASS, f"{roughness.describe()}: the input mesh comes back, {fine_pass_effect(params)}",
                     roughness=roughness)
    reason = (f"{roughness.describe()}: the voxel stage measures it" if routed
              else f"output_mesh {params.output_mesh}" if params.output_mesh != "auto"
              else "a voxel mesh: the voxel stage tells its noise from its steps" if lattice is not None
              else "voxel-stage parameters given")
    return Route(VOXEL_STAGE, reason, output=params.output_mesh, roughness=roughness)


def fine_pass_effect(params):
    """What happens to an input mesh that comes back as itself, in the words of a note."""
    return "as it is (fine pass off)" if params.fine_pass == "off" else "smoothed by the fine pass"
