"""The grid's neighbourhood operations against scipy's on small grids, and the mesh's vertex welding
against numpy's rows."""

import numpy as np
import pytest
import trimesh
from scipy import ndimage

from skelfilter.core.neighbourhood import dilated_by_cross, dilated_by_cube, surface_voxels
from skelfilter.mesh.marching_cubes import _signed_volume
from skelfilter.mesh.welding import weld

SHAPES = [(1, 1, 1), (1, 5, 3), (2, 2, 2), (7, 3, 9), (17, 18, 19)]


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("share", [0.05, 0.5, 0.95])
def test_dilated_by_cube_is_scipys_dilation_by_the_cube(shape, share):
    volume = np.random.default_rng(len(shape) * 7 + int(100 * share)).random(shape) < share
    expected = ndimage.binary_dilation(volume, structure=np.ones((3, 3, 3), bool))
    assert np.array_equal(dilated_by_cube(volume), expected)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("share", [0.05, 0.5, 0.95, 1.0])
def test_surface_voxels_are_the_set_less_its_erosion(shape, share):
    volume = np.random.default_rng(int(np.prod(shape)) + int(100 * share)).random(shape) < share
    expected = volume & ~ndimage.binary_erosion(volume)
    assert np.array_equal(surface_voxels(volume), expected)


def test_weld_is_numpys_unique_rows():
    rng = np.random.default_rng(3)
    vertices = np.round(rng.normal(size=(2000, 3)), 1)  # many coincide
    vertices[::7] = -0.0  # signed zeros equal zeros
    vertices = np.concatenate([vertices, vertices[rng.permutation(len(vertices))[:500]]])
    welded, inverse = weld(vertices)
    expected, expected_inverse = np.unique(vertices, axis=0, return_inverse=True)
    assert np.array_equal(welded, expected)
    assert np.array_equal(inverse, expected_inverse.reshape(-1))
    assert np.array_equal(welded[inverse], vertices)
    assert weld(np.zeros((0, 3)))[0].shape == (0, 3)


def test_signed_volume_is_trimeshs_volume():
    mesh = trimesh.creation.icosphere(subdivisions=3, radius=1.7)
    mesh.apply_translation([3.0, -2.0, 1.0])
    assert _signed_volume(mesh.vertices, mesh.faces) == pytest.approx(mesh.volume, rel=1e-12)
    mesh.invert()
    assert mesh.volume < 0
    assert _signed_volume(mesh.vertices, mesh.faces) == pytest.approx(mesh.volume, rel=1e-12)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("iterations", [1, 2, 3])
def test_dilated_by_cross_is_scipys_iterated_dilation(shape, iterations):
    volume = np.random.default_rng(int(np.prod(shape)) + iterations).random(shape) < 0.05
    expected = ndimage.binary_dilation(volume, iterations=iterations)
    assert np.array_equal(dilated_by_cross(volume, iterations), expected)
