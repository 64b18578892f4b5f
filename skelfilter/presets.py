"""The presets of the filter parameters (:mod:`skelfilter.params`).

Three presets fix the method's main choices: ``thesis`` is the thesis' pipeline as printed, with its
defaults (§8.1.1-8.1.2: both stages, t = 18 voxels, eq. 5.6 as printed); ``thesis-tuned`` the same with
two readings this project took before following the text literally (rho+ from the neighbours ahead
along v, no derivative below rho = 7 voxels), kept so that its figures stay reproducible; ``default``
is what measured best on this project's quality benchmark (``benchmarks/quality.py``): the foreground
stage only and t = 30 voxels of a 160-voxel grid, scaled with the resolution. Fields left unset
(``None``, or ``"preset"`` for a choice) take the preset's value.
"""

# What each preset sets when the field is left unset.
_THESIS = {"stages": "both", "threshold": 18.0, "threshold_relative": None, "cap_factor": 2.0,
           "unchanged_surface": "reconstruction", "thin_radius_relative": 1.0, "output_mesh": "closed",
           "keep_features": "off", "prune": "as-told", "fine_pass": "off", "surface": "plain"}
PRESETS = {
    "default": {"stages": "auto", "threshold": None, "threshold_relative": 30.0 / 160.0,
                "cap_factor": 1.0, "unchanged_surface": "input", "thin_radius_relative": 4.0 / 160.0,
                "output_mesh": "auto", "keep_features": "on", "prune": "measured", "fine_pass": "auto",
                "rho_plus_from": "ahead", "derivative_min_rho": 7.0, "surface": "smooth"},
    # §8.1.1-8.1.2 as printed: eq. 5.6 over every visited neighbour, sigma_bar wherever eq. 4.3 allows
    # and the voxel has two distinct feature points (rho >= 1; rho = 0 has no feature pair, eq. 3.6).
    "thesis": {**_THESIS, "rho_plus_from": "any", "derivative_min_rho": 1.0},
    # The thesis preset before it followed the text literally (its figures are kept bit for bit):
    # rho+ from the neighbours ahead along v and no sigma_bar below rho = 7, as the default.
    "thesis-tuned": {**_THESIS, "rho_plus_from": "ahead", "derivative_min_rho": 7.0},
}
# The cap of the geodesic searches for the rules that read rho itself (eq. 3.1, 4.2 with Gamma_y), in units
# of t: rho past it is far above any noise, and the measures are taken as met there (the cap hides their
# value: rho would be constant along the core, sigma_bar 0 and rho / D falling). Uncapped, the searches
# across thin walls go round the rim and take hours on a mug at 276 voxels.
RHO_RULE_CAP_FACTOR = 4.0
# The fields a preset fills where they are left unset ("preset" for a choice, None for a number).
PRESET_CHOICES = ("stages", "unchanged_surface", "output_mesh", "keep_features", "prune", "fine_pass",
                  "rho_plus_from", "surface")
