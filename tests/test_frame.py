"""Scale and position do not matter: a mesh scaled by 1e-9 ... 1e9 or moved far from the origin gives
the same result up to that scale and shift (skelfilter.mesh.frame), and files keep tiny meshes whole."""

from pathlib import Path

import numpy as np
import pytest
import trimesh

from skelfilter.errors import InputError
from skelfilter.io import mesh_files
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.mesh.frame import Frame

DATA = Path(__file__).parent / "data"
FANDISK = Path(__file__).parent.parent / "skelfilter" / "data" / "fandisk.obj"


@pytest.fixture(scope="module")
def fandisk():
    return trimesh.load(str(FANDISK), process=False)


@pytest.fixture(scope="module")
def scan():
    return mesh_files.load_mesh(DATA / "range-scan-bunny.ply")


def _moved(mesh, scale, shift):
    out = mesh.copy()
    out.vertices = np.asarray(mesh.vertices) * scale + shift
    return out


def _deviations(out, reference, scale, shift):
    """Per vertex: the largest coordinate difference to the corresponding vertex, in the reference's units."""
    assert out.faces.shape == reference.faces.shape and np.array_equal(out.faces, reference.faces)
    return np.abs((np.asarray(out.vertices) - shift) / scale - reference.vertices).max(axis=1)


def _deviation(out, reference, scale, shift):
    """Largest distance between corresponding vertices, back in the reference's units."""
    return _deviations(out, reference, scale, shift).max()


@pytest.mark.parametrize("kind", ["closed", "kept", "noise"])
def test_scale_and_shift_do_not_change_the_result(fandisk, scan, kind):
    mesh, run = {
        "closed": (fandisk, lambda m: mesh_pipeline.denoise_mesh(m, resolution=40, output_mesh="closed")),
        "kept": (scan, lambda m: mesh_pipeline.denoise_mesh(m, resolution=40)),
        "noise": (fandisk, lambda m: mesh_pipeline.noisy_mesh(m, resolution=40, seed=3)[0]),
    }[kind]
    reference = run(mesh)
    size = np.ptp(mesh.vertices, axis=0).max()
    # A power of two is exact: bit-identical coordinates.
    assert _deviation(run(_moved(mesh, 2.0**-30, 0.0)), reference, 2.0**-30, 0.0) == 0
    for scale, shift in ((1e-9, 0.0), (1e9, 0.0), (1.0, 1e11), (3.7e-4, -5e6)):
        out = run(_moved(mesh, scale, shift))
        # Distances in the closed output, which is the input's own surface wherever
        # nothing changed (all of a clean mesh: measured 1.2e-6 of the size); the far-off input's own rounding.
        tolerance = 2e-6 * size + 4 * np.spacing(abs(shift)) / scale
        if kind == "closed" and shift:
            # Marching cubes of those distances where they are near 0 at a grid vertex: the far-off
            # input's rounding moves such a crossing by up to 1.5e-4 of the size (measured; an open
            # item of issue 17, where the unchanged closed output became the input's surface).
            tolerance = 2e-4 * size
        if kind == "kept" and shift:
            # The fine pass repairs faces it folded (vertex_projection.unfold), a yes/no per face: the
            # far-off input's rounding flipped it for one face of the scan (2 folded faces against 1;
            # measured), whose 3 corners then differ by 0.57 of an edge. Everything else within rounding.
            off = _deviations(out, reference, scale, shift) > tolerance
            assert off.sum() <= 3, (scale, shift)
            assert _deviations(out, reference, scale, shift).max() <= mesh.edges_unique_length.mean()
            continue
        assert _deviation(out, reference, scale, shift) <= tolerance, (scale, shift)


def test_tiny_box_survives_denoising_and_every_text_format(tmp_path):
    box = trimesh.creation.box()
    tiny = _moved(box, 1e-8, 0.0)
    out = mesh_pipeline.denoise_mesh(tiny, resolution=32, output_mesh="closed")
    assert out.is_watertight and out.volume == pytest.approx(1e-24, rel=0.05)
    assert np.ptp(out.vertices, axis=0) == pytest.approx([1e-8] * 3, rel=0.05)
    for ext in ("ply", "obj", "off", "stl"):
        mesh_files.save_mesh(tiny, tmp_path / f"tiny.{ext}")
        back = mesh_files.load_mesh(tmp_path / f"tiny.{ext}")
        assert np.allclose(np.unique(back.vertices, axis=0), np.unique(tiny.vertices, axis=0), rtol=1e-6, atol=0)


def test_single_precision_formats_refuse_a_small_far_mesh(tmp_path):
    far = _moved(trimesh.creation.box(), 1e-3, 1e9)
    with pytest.raises(InputError, match="single precision"):
        mesh_files.save_mesh(far, tmp_path / "far.stl")
    assert list(tmp_path.iterdir()) == []
    mesh_files.save_mesh(far, tmp_path / "far.ply")
    assert np.array_equal(mesh_files.load_mesh(tmp_path / "far.ply").vertices, far.vertices)


def test_frame_is_a_power_of_two_around_the_bounding_box():
    box = _moved(trimesh.creation.box(extents=(3.0, 1.0, 0.5)), 1.0, (10.0, -4.0, 2.0))
    frame = Frame.of(box)
    assert np.allclose(frame.centre, (10.0, -4.0, 2.0)) and frame.scale == 4.0
    unit = frame.to_unit(box)
    assert np.abs(unit.vertices).max() <= 1.0
    assert np.array_equal(frame.to_world(unit.copy()).vertices, box.vertices)
