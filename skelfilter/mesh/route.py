"""The route a mesh takes through the pipeline: decided in one place (`choose`), carried out by
:mod:`skelfilter.mesh.pipeline`, and handed to the caller with the output (`Route`).

Three routes (`ROUTES`):

- ``as it was``: a clean mesh (`output_choice.Roughness` finds no noise) comes back unchanged, nothing
  voxelized;
- ``fine pass``: the voxel stage does not run (the noise is finer than the skeleton's scale, or the
  input is an open surface): the input mesh comes back, its vertices smoothed by the fine pass where it
  is noisy (`skelfilter.mesh.fine_pass`);
- ``voxel stage``: the skeleton denoiser runs on the mesh's voxels; the output is a new closed mesh
  (``closed``) or the input mesh with its vertices moved (``input``).

`choose` decides what can be decided before voxelizing, from the input's roughness
(`output_choice.measure`) and the parameters; the voxel stage settles the rest (a surface that is not a
solid goes to the fine pass; ``output_mesh`` auto becomes closed where noise at the skeleton's scale was
pruned), and `Route.settled` records it.
"""

from dataclasses import dataclass, field, replace

from skelfilter.mesh import output_choice

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
    roughness : output_choice.Roughness or None
        The input's surface roughness, where it was measured (not on a voxel mesh, which goes to the
        voxel stage).
    noise : dict
        ``"foreground"`` / ``"background"`` -> `skelfilter.core.noise_estimate.NoiseEstimate`, the
        noise each stage measured, where the voxel stage ran.
    fine_pass : bool
        Whether the fine pass smoothed the output's vertices (before voxelizing, for a closed output).
    """

    kind: str
    reason: str
    output: str = "input"
    roughness: output_choice.Roughness | None = None
    noise: dict = field(default_factory=dict)
    fine_pass: bool = False

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
        return {"route": self.kind, "output": self.output, "reason": self.reason, "fine_pass": self.fine_pass,
                "roughness": roughness, "noise": noise}


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
            roughness = output_choice.measure(mesh)
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
