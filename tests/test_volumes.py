"""Volumes in (NIfTI, NRRD, TIFF, VTK image data, .npy): spacing and affine honoured, header kept, labels kept."""

import subprocess
import sys

import nibabel
import nrrd
import numpy as np
import pytest
import tifffile
from scipy import ndimage
from scipy.spatial.transform import Rotation

from skelfilter.core import pipeline
from skelfilter.core import spacing as voxel_spacing
from skelfilter.errors import InputError
from skelfilter.io import formats, mesh_files, volume_files
from skelfilter.jobs import denoise_file
from skelfilter.params import DenoiseParams, VolumeParams

# A single bump is no noise spread over the surface: the default keeps it (keep_features); these tests
# are about the volume's geometry, so they prune as told.
PRUNE = DenoiseParams(keep_features="off", prune="as-told")

SIZE = 64.0  # mm, the phantom's field of view
RADIUS, BUMP = 20.0, 2.0  # a 40 mm ball with a 2 mm half-ball bump on it


def phantom(spacing):
    """The ball with its bump sampled at ``spacing`` (mm): (mask, ball, protruding part of the bump)."""
    spacing = np.asarray(spacing, dtype=float)
    shape = np.ceil(SIZE / spacing).astype(int)
    p = (np.indices(shape).reshape(3, -1).T + 0.5) * spacing - SIZE / 2
    r = np.linalg.norm(p, axis=1)
    bump = np.linalg.norm(p - [RADIUS, 0.0, 0.0], axis=1) <= BUMP
    ball = r <= RADIUS
    return (ball | bump).reshape(shape), ball.reshape(shape), (bump & (r > RADIUS + 0.75)).reshape(shape)


def rotated_affine(spacing):
    affine = np.eye(4)
    affine[:3, :3] = Rotation.from_euler("xyz", [20, -35, 50], degrees=True).as_matrix() * spacing
    affine[:3, 3] = (10.0, -20.0, 30.0)
    return affine


def mostly_gone(mask, bump):
    """At most a tenth of the bump's protruding voxels left."""
    return bump.any() and (mask & bump).sum() <= 0.1 * bump.sum()


@pytest.mark.parametrize("spacing", [(1.0, 1.0, 1.0), (0.5, 0.5, 0.5), (0.7, 0.7, 0.7), (0.5, 0.5, 1.0),
                                     (0.5, 0.5, 1.5), (1.5, 0.5, 0.5), (1.0, 1.0, 0.5)])
def test_a_bump_of_the_same_physical_size_goes_whatever_the_spacing(spacing):
    mask, ball, bump = phantom(spacing)
    result = pipeline.denoise_volume(mask, spacing=spacing, keep_features="off", prune="as-told")
    assert mostly_gone(result.mask, bump)
    # The ball stays; what goes is the stair-step shell of its digitization (under a voxel deep).
    assert (ball & result.mask).sum() >= 0.93 * ball.sum() and result.mask.shape == mask.shape


def test_resampling_round_trips_a_mask():
    mask, _, _ = phantom((0.5, 0.5, 1.5))
    field, pitch = voxel_spacing.to_isotropic(mask, (0.5, 0.5, 1.5))
    assert pitch == 0.5 and field.shape == (128, 128, 129)
    back = voxel_spacing.from_isotropic(field, (0.5, 0.5, 1.5), mask.shape) > 0
    assert (back != mask).sum() <= 0.002 * mask.sum()


@pytest.fixture(scope="module")
def nifti(tmp_path_factory):
    spacing = np.array([0.5, 0.5, 1.5])
    mask, _, _ = phantom(spacing)
    path = tmp_path_factory.mktemp("nifti") / "phantom.nii.gz"
    image = nibabel.Nifti1Image(mask.astype(np.uint8), rotated_affine(spacing))
    image.header["descrip"] = b"skelfilter test phantom"
    nibabel.save(image, path)
    return path


def test_nifti_out_keeps_header_and_affine_and_mesh_lies_on_the_mask_in_world(nifti, tmp_path):
    before = nifti.read_bytes()
    for name in ("out.nii.gz", "out.ply"):
        r = subprocess.run([sys.executable, "-m", "skelfilter.cli", "denoise", str(nifti), str(tmp_path / name),
                            "--keep-features", "off", "--prune", "as-told"],
                           capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, r.stderr
    assert nifti.read_bytes() == before
    source, out = nibabel.load(nifti), nibabel.load(tmp_path / "out.nii.gz")
    assert np.array_equal(out.affine, source.affine) and out.shape == source.shape
    assert out.header["descrip"] == source.header["descrip"] and out.get_data_dtype() == np.uint8
    denoised = np.asarray(out.dataobj) > 0
    assert mostly_gone(denoised, phantom((0.5, 0.5, 1.5))[2])
    mesh = mesh_files.load_mesh(tmp_path / "out.ply")
    assert mesh.is_watertight and mesh.volume > 0
    # The mesh, taken back to voxel indices, lies on the written mask's surface: the half-way level
    # of the mask's signed distance (mm), sampled where the vertices fall.
    index = (mesh.vertices - source.affine[:3, 3]) @ np.linalg.inv(source.affine[:3, :3]).T
    distance = voxel_spacing.signed_distance(denoised, (0.5, 0.5, 1.5))
    at_vertices = ndimage.map_coordinates(distance, index.T, order=1, mode="nearest")
    assert np.abs(at_vertices).mean() < 0.25  # half the finest voxel side
    # ... and on the ball in world coordinates, the stair-steps of the thick slices smoothed away.
    centre = source.affine[:3, :3] @ (SIZE / 2 / np.array([0.5, 0.5, 1.5]) - 0.5) + source.affine[:3, 3]
    off = np.linalg.norm(mesh.vertices - centre, axis=1) - RADIUS
    assert np.abs(off).mean() < 0.5 * np.cbrt(0.5 * 0.5 * 1.5)


def test_nrrd_and_tiff_round_trip(tmp_path):
    mask, _, bump = phantom((0.5, 0.5, 1.0))
    header = {"space": "left-posterior-superior", "space directions": np.diag([0.5, 0.5, 1.0]),
              "space origin": np.array([1.0, 2.0, 3.0]), "content": "phantom"}
    nrrd.write(str(tmp_path / "in.nrrd"), mask.astype(np.uint8), header)
    tifffile.imwrite(tmp_path / "in.tif", np.ascontiguousarray(mask.astype(np.uint8).T), imagej=True,
                     resolution=(2.0, 2.0), metadata={"spacing": 1.0, "unit": "mm"})
    for name in ("in.nrrd", "in.tif"):
        source = volume_files.load_volume(tmp_path / name)
        assert np.array_equal(source.data.astype(bool), mask) and np.allclose(source.spacing, (0.5, 0.5, 1.0))
        out = tmp_path / name.replace("in", "out")
        denoise_file.denoise_file(tmp_path / name, out, PRUNE)
        back = volume_files.load_volume(out)
        assert np.array_equal(back.affine, source.affine) and back.data.shape == mask.shape
        assert mostly_gone(back.data.astype(bool), bump)
    assert nrrd.read_header(str(tmp_path / "out.nrrd"))["content"] == "phantom"


def test_world_coordinates_are_ras_whatever_the_files_convention(tmp_path):
    """A Slicer NRRD (left-posterior-superior) made into a NIfTI and a mesh: both in RAS."""
    mask, _, _ = phantom((1.0, 1.0, 1.0))
    lps = np.diag([1.0, 1.0, 1.0])
    nrrd.write(str(tmp_path / "lps.nrrd"), mask.astype(np.uint8),
               {"space": "left-posterior-superior", "space directions": lps, "space origin": np.array([5.0, 6.0, 7.0])})
    denoise_file.denoise_file(tmp_path / "lps.nrrd", tmp_path / "out.nii.gz", DenoiseParams())
    denoise_file.denoise_file(tmp_path / "lps.nrrd", tmp_path / "out.ply", DenoiseParams())
    assert np.allclose(nibabel.load(tmp_path / "out.nii.gz").affine,
                       [[-1, 0, 0, -5], [0, -1, 0, -6], [0, 0, 1, 7], [0, 0, 0, 1]])
    centre = np.array([-5.0, -6.0, 7.0]) + [-31.5, -31.5, 31.5]  # voxel (31.5, 31.5, 31.5) in RAS
    assert np.allclose(mesh_files.load_mesh(tmp_path / "out.ply").bounds.mean(axis=0), centre + [-0.5 * BUMP, 0, 0],
                       atol=1.0)
    nrrd.write(str(tmp_path / "odd.nrrd"), mask.astype(np.uint8), {"space": "scanner-xyz"})
    with pytest.raises(InputError, match="NRRD space 'scanner-xyz' is not supported"):
        volume_files.load_volume(tmp_path / "odd.nrrd")


def test_a_plain_tiff_has_unit_spacing(tmp_path):
    """Not ImageJ's: its resolution is dots per inch, not a voxel size."""
    tifffile.imwrite(tmp_path / "plain.tif", np.zeros((4, 5, 6), np.uint8), resolution=(72.0, 72.0))
    assert np.array_equal(volume_files.load_volume(tmp_path / "plain.tif").spacing, [1.0, 1.0, 1.0])


@pytest.mark.parametrize("name", sorted(formats.VOLUME_FORMATS))
def test_every_volume_format_of_the_table_round_trips_and_is_a_volume_everywhere(tmp_path, name):
    """Each module of skelfilter/io/volume_formats, found by the table: its files are volumes for every
    entry point, and what it writes it reads back (data, spacing and origin; NumPy has no geometry)."""
    suffix = formats.VOLUME_FORMATS[name].suffixes[0]
    labels = np.zeros((7, 6, 5), dtype=np.uint8)
    labels[2:5, 1:4, 1:3] = 3
    affine = np.diag([0.5, 0.75, 1.5, 1.0])
    affine[:3, 3] = (1.0, -2.0, 3.0)
    kept = {"npy": "nothing", "tiff": "spacing"}.get(name, "affine")  # what the format stores of the geometry
    if kept != "affine":
        affine[:3, 3] = 0.0
    if kept == "nothing":
        affine[:3, :3] = np.eye(3)
    path = tmp_path / f"v{suffix}"
    volume_files.save_volume(path, volume_files.Volume(labels, affine, "npy"), labels)
    assert formats.file_kind(path) == formats.input_kind(path) == "volume"
    back = volume_files.load_volume(path)
    assert np.array_equal(back.data, labels) and np.allclose(back.affine, affine), name
    assert denoise_file.check_paths(path, tmp_path / f"out{suffix}") == ("volume", "volume")


def test_vtk_image_data_round_trips_a_label_map(tmp_path):
    """A .vti label map as ParaView or pyvista writes it (x varies fastest, origin and spacing):
    read on its grid, one label denoised, written back with its name, every other label kept."""
    import pyvista

    mask, _, bump = phantom((0.5, 0.5, 1.0))
    labels = np.where(mask, 4, 0).astype(np.uint8)
    labels[:6] = 9
    image = pyvista.ImageData(dimensions=mask.shape, spacing=(0.5, 0.5, 1.0), origin=(1.0, 2.0, 3.0))
    image.point_data["tissue"] = labels.ravel(order="F")
    image.save(tmp_path / "in.vti")
    source = volume_files.load_volume(tmp_path / "in.vti")
    assert np.array_equal(source.data, labels) and np.allclose(source.spacing, (0.5, 0.5, 1.0))
    assert np.allclose(source.affine[:3, 3], (1.0, 2.0, 3.0))
    denoise_file.denoise_file(tmp_path / "in.vti", tmp_path / "out.vti", PRUNE, VolumeParams(label=4))
    back = pyvista.read(tmp_path / "out.vti")
    assert back.dimensions == mask.shape and np.allclose(back.spacing, (0.5, 0.5, 1.0))
    out = np.asarray(back.point_data["tissue"]).reshape(mask.shape, order="F")
    assert np.array_equal(out[labels == 9], labels[labels == 9]) and mostly_gone(out == 4, bump)
    assert np.array_equal(volume_files.load_volume(tmp_path / "out.vti").affine, source.affine)


def test_a_vti_array_name_with_xml_characters_is_written_back_as_it_was(tmp_path):
    import pyvista

    mask, _, _ = phantom((1.0, 1.0, 1.0))
    image = pyvista.ImageData(dimensions=mask.shape)
    image.point_data["mask"] = mask.astype(np.uint8).ravel(order="F")
    image.save(tmp_path / "in.vti")
    name = 'a "b" <c> & d'
    text = (tmp_path / "in.vti").read_bytes().replace(b'"mask"', b'"a &quot;b&quot; &lt;c&gt; &amp; d"')
    (tmp_path / "in.vti").write_bytes(text)
    source = volume_files.load_volume(tmp_path / "in.vti")
    assert source.header["name"] == name
    volume_files.save_volume(tmp_path / "out.vti", source, source.data)
    back = volume_files.load_volume(tmp_path / "out.vti")
    assert back.header["name"] == name and np.array_equal(back.data, source.data)


def test_a_label_map_keeps_every_other_label(tmp_path):
    mask, _, bump = phantom((1.0, 1.0, 1.0))
    labels = np.where(mask, 3, 0).astype(np.int16)
    labels[:8] = 7  # another structure, touching nothing
    labels[56:60, 30:34, 30:34] = 5  # and one just outside the ball
    np.save(tmp_path / "labels.npy", labels)
    denoise_file.denoise_file(tmp_path / "labels.npy", tmp_path / "out.npy", PRUNE, VolumeParams(label=3))
    out = np.load(tmp_path / "out.npy")
    assert out.dtype == labels.dtype
    others = (labels != 3) & (labels != 0)
    assert np.array_equal(out[others], labels[others])
    assert not (out[bump] == 3).any() and set(np.unique(out)) == {0, 3, 5, 7}


@pytest.mark.parametrize("suffix", ["nii.gz", "tif"])
def test_a_0_255_mask_comes_back_0_255(tmp_path, suffix):
    """An 8-bit image mask (ImageJ/Fiji, many NIfTI exports) keeps its set value: a tool thresholding
    at 128 sees the output's shape, not an empty mask."""
    mask, _, bump = phantom((1.0, 1.0, 1.0))
    image = np.where(mask, 255, 0).astype(np.uint8)
    path = tmp_path / f"mask.{suffix}"
    if suffix == "tif":
        tifffile.imwrite(path, image)
    else:
        nibabel.save(nibabel.Nifti1Image(image, np.eye(4)), path)
    denoise_file.denoise_file(path, tmp_path / f"out.{suffix}", PRUNE)
    out = volume_files.load_volume(tmp_path / f"out.{suffix}").data
    assert out.dtype == np.uint8 and set(np.unique(out)) == {0, 255}
    assert not (out[bump] == 255).any() and (out == 255).sum() > 0.9 * mask.sum()


@pytest.mark.parametrize("data, params, message", [
    (np.arange(27).reshape(3, 3, 3), {}, "holds 27 values, not a mask"),
    (np.zeros((8, 8, 8)), {}, "no voxel is set"),
    (np.ones((8, 8, 8)) * 2, {"label": 3}, "label 3 selects no voxel"),
    (np.zeros((8, 8, 8)), {"iso": 0.5}, "no voxel is at or above the iso level 0.5"),
    (np.zeros((8, 8)), {}, "a volume must be 3-D"),
])
def test_bad_volumes_are_refused(tmp_path, data, params, message):
    np.save(tmp_path / "v.npy", data)
    with pytest.raises(InputError, match=message):
        denoise_file.denoise_file(tmp_path / "v.npy", tmp_path / "o.npy", DenoiseParams(), VolumeParams(**params))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v.npy"]


def test_a_mesh_gives_no_volume(tmp_path):
    import trimesh
    trimesh.creation.box().export(tmp_path / "cube.ply")
    with pytest.raises(InputError, match="a mesh input gives a mesh output"):
        denoise_file.denoise_file(tmp_path / "cube.ply", tmp_path / "o.nii.gz", DenoiseParams())


def test_python_api_takes_an_affine():
    import skelfilter

    box = np.zeros((30, 30, 30), dtype=bool)
    box[5:25, 5:25, 5:20] = True
    affine = np.diag([0.5, 0.5, 1.0, 1.0])
    affine[:3, 3] = (100.0, 0.0, -50.0)
    result = skelfilter.denoise_volume(box, affine=affine, keep_features="off", prune="as-told")
    # A clean box passes through but for a rounding of its edges (a voxel's width: the skeleton
    # sheets that reach the edges are pruned).
    on_faces = [box & ~ndimage.binary_erosion(box, np.ones(shape)) for shape in ((3, 1, 1), (1, 3, 1), (1, 1, 3))]
    edges = np.sum(on_faces, axis=0) >= 2
    assert not (result.mask & ~box).any() and not (box & ~result.mask & ~edges).any()
    mesh = skelfilter.field_to_world_mesh(result.field, affine)
    # faces half-way between the set voxel centres and the next ones, in world coordinates
    assert np.allclose(mesh.bounds, [[102.25, 2.25, -45.5], [112.25, 12.25, -30.5]], atol=0.05)


@pytest.mark.parametrize("spacing, preset", [(None, "default"), ((1.0, 1.0, 1.5), "default"),
                                             ((0.7, 1.0, 1.0), "default"), ((1.0, 1.0, 1.5), "thesis")])
def test_a_label_costs_its_box_and_the_output_does_not_depend_on_the_crop(spacing, preset, monkeypatch):
    # a noisy blob in one corner of a much larger scan
    rng = np.random.default_rng(3)
    volume = np.zeros((90, 80, 50), dtype=bool)
    z, y, x = np.ogrid[:90, :80, :50]
    wobble = ndimage.gaussian_filter(rng.normal(size=volume.shape), 1.0) * 2.0  # segmentation-like noise
    volume[((z - 25) / 12.0) ** 2 + ((y - 22) / 10.0) ** 2 + ((x - 18) / 8.0) ** 2 < 1 + wobble] = True
    cropped = pipeline.denoise_volume(volume, spacing=spacing, preset=preset)
    assert cropped.mask.shape == cropped.field.shape == volume.shape
    assert cropped.voxels_changed == int((cropped.mask != volume).sum()) > 0
    monkeypatch.setattr(pipeline, "CROP_MARGIN", 1000)  # the box is the whole volume
    whole = pipeline.denoise_volume(volume, spacing=spacing, preset=preset)
    assert np.array_equal(cropped.mask, whole.mask)
    box = pipeline.bounding_box(volume, margin=12)
    assert np.array_equal(cropped.field[box] > 0, whole.field[box] > 0)


@pytest.mark.parametrize("side", [1, 2, 3, 4])
def test_a_shape_too_small_for_a_skeleton_comes_back(side):
    """A cube of 2 or 4 voxels has no IE skeleton at all; it is kept as it is, not a crash."""
    mask = np.zeros((8, 8, 8), dtype=bool)
    mask[2:2 + side, 2:2 + side, 2:2 + side] = True
    out = pipeline.denoise_volume(mask, DenoiseParams()).mask
    assert out.shape == mask.shape and not (out & ~mask).any()


@pytest.mark.parametrize("dtype, label", [(np.float16, 1), (np.int64, 2**40), (np.uint64, 7)])
def test_every_volume_format_takes_every_real_type(tmp_path, dtype, label):
    """A clean label map read from .npy (any real NumPy type) passes through to every format of the
    table, its values as they were (half floats as single ones); complex data is refused."""
    labels = np.zeros((12, 12, 12), dtype=dtype)
    labels[3:9, 3:9, 3:9] = label
    np.save(tmp_path / "in.npy", labels)
    for name, fmt in formats.VOLUME_FORMATS.items():
        out = tmp_path / f"out{fmt.suffixes[0]}"
        denoise_file.denoise_file(tmp_path / "in.npy", out, DenoiseParams(), VolumeParams(label=label))
        back = volume_files.load_volume(out).data
        assert np.array_equal(back, labels.astype(np.float32) if dtype == np.float16 else labels), name
    np.save(tmp_path / "complex.npy", labels.astype(np.complex64))
    with pytest.raises(InputError, match="is complex"):
        denoise_file.denoise_file(tmp_path / "complex.npy", tmp_path / "c.npy", PRUNE)


def test_an_ome_tiff_keeps_its_physical_voxel_size(tmp_path):
    """A microscope's OME-TIFF states its voxel size in the OME-XML (PhysicalSizeX/Y/Z), not as ImageJ
    metadata: it is the spacing, and a TIFF output states it again."""
    mask, _, bump = phantom((1.0, 1.0, 4.0))
    tifffile.imwrite(tmp_path / "in.ome.tif", np.ascontiguousarray(mask.astype(np.uint8).T), ome=True,
                     metadata={"axes": "ZYX", "PhysicalSizeX": 0.25, "PhysicalSizeY": 0.25, "PhysicalSizeZ": 1.0,
                               "PhysicalSizeXUnit": "µm", "PhysicalSizeYUnit": "µm", "PhysicalSizeZUnit": "µm"})
    source = volume_files.load_volume(tmp_path / "in.ome.tif")
    assert np.allclose(source.spacing, (0.25, 0.25, 1.0)) and np.array_equal(source.data.astype(bool), mask)
    denoise_file.denoise_file(tmp_path / "in.ome.tif", tmp_path / "out.tif", PRUNE)
    back = volume_files.load_volume(tmp_path / "out.tif")
    assert np.allclose(back.spacing, (0.25, 0.25, 1.0)) and back.data.shape == mask.shape
    with tifffile.TiffFile(tmp_path / "out.tif") as tif:
        assert tif.is_ome and 'PhysicalSizeZ="1.0"' in tif.ome_metadata
