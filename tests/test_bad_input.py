"""Bad or extreme input through the CLI: one line ``skelfilter: error: …``, exit 2, the input unchanged
and nothing left behind (issue: reliability). More cases live in test_cli.py and test_run_script.py."""

import hashlib
import os
import resource
import subprocess
import sys

import nibabel
import numpy as np
import pytest
import trimesh

from skelfilter import DenoiseParams, NoiseParams
from skelfilter.core import pipeline
from skelfilter.errors import InputError, ParameterError, ResourceError
from skelfilter.io import mesh_files
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.meshlab.scripts import run_filter_script

SCRIPT = '<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name="Taubin Smooth"/>\n</FilterScript>\n'

# (arguments, a piece of the expected message); {in}, {out}, {dir}, {file}, {script} are filled in
CASES = [
    (["denoise", "{in}", "{dir}"], "unsupported format ''"),
    (["denoise", "{in}", "{out}", "--resolution", str(2**63)], "resolution must be an integer in [16, 4096]"),
    (["denoise", "{in}", "{out}", "--resolution", "8"], "resolution must be an integer in [16, 4096]"),
    (["denoise", "{in}", "{out}", "--threshold", "1e30"], "threshold must be a number in"),
    (["denoise", "{in}", "{out}", "--threshold", "nan"], "threshold must be a number in"),
    (["denoise", "{in}", "{out}", "--k", "nan"], "k must be a number in [0, 100]"),
    (["denoise", "{in}", "{out}", "--k", "inf"], "k must be a number in [0, 100]"),
    (["denoise", "{in}", "{out}", "--k", "-1"], "k must be a number in [0, 100]"),
    (["denoise", "{in}", "{out}", "--derivative-guard", "nan"], "derivative_guard must be a number"),
    (["denoise", "{in}", "{out}", "--minify-radius", "inf"], "minify_radius must be a number"),
    (["denoise", "{in}", "{out}", "--geodesic-cap", "-5"], "geodesic_cap must be a number"),
    (["denoise", "{in}", "{out}", "--padding", "1"], "padding must be an integer in [2, 4096]"),
    (["denoise", "{in}", "{out}", "--resolution", "abc"], "invalid int value"),
    (["denoise", "{in}", "{out}", "--output-mesh", "cube"], "invalid choice"),
    (["denoise", "{in}", "{out}", "--close", "--output-mesh", "input"], "--close contradicts"),
    (["denoise", "{in}"], "the following arguments are required"),
    (["denoise", "{in}", "{out}.xyz"], "a mesh input gives a mesh output"),
    (["denoise", "{in}", "{out}.abc"], "unsupported format 'abc'"),
    (["denoise", "{in}", "{in}"], "refusing to overwrite the input file"),
    (["noise", "{in}", "{out}", "--r", "nan"], "r must be a number in"),
    (["noise", "{in}", "{out}", "--r", "inf"], "r must be a number in"),
    (["noise", "{in}", "{out}", "--seed", "-1"], "seed must be an integer in"),
    (["noise", "{in}", "{out}", "--l", "1000000000"], "l must be an integer in [1, 100000]"),
    (["noise", "{in}", "{out}", "--p", "2"], "p must be a number in [0, 1]"),
    (["noise", "{in}", "{out}", "--h", "-3"], "h must be an integer in"),
    (["run-script", "{script}", "{in}", "{out}", "--timeout", "nan"], "must be a number of seconds"),
    (["run-script", "{script}", "{in}", "{out}", "--timeout", "0"], "must be a number of seconds"),
    (["run-script", "{script}", "{in}", "{out}", "--timeout", "-1"], "must be a number of seconds"),
    (["compare", "{dir}", "--out", "{dir}/report"], "no input file of a supported kind"),
    (["compare", "--out", "{file}"], "exists and is not a folder"),
    (["frobnicate"], "invalid choice"),
    # malformed or unusable input files
    (["denoise", "{root}/objtext.stl", "{out}"], "malformed STL file (binary STL: the header promises"),
    (["denoise", "{root}/falsecount.stl", "{out}"], "the header promises 1000 triangles"),
    (["denoise", "{root}/morevert.ply", "{out}"], "the header declares 50 vertices"),
    (["denoise", "{root}/garbage.obj", "{out}"], "malformed OBJ file (no triangles could be read"),
    (["denoise", "{root}/empty.off", "{out}"], "the file is empty"),
    (["denoise", "{root}/short.off", "{out}"], "malformed OFF file"),
    (["denoise", "{root}/nan.obj", "{out}"], "vertex coordinates contain NaN or infinity"),
    (["denoise", "{root}/point.obj", "{out}"], "all vertices coincide"),
    (["denoise", "{root}/adir.ply", "{out}"], "is a folder, not a mesh file"),
    (["denoise", "{root}/missing.ply", "{out}"], "no such file"),
    (["noise", "{root}/garbage.obj", "{out}"], "malformed OBJ file"),
    (["denoise", "{root}/apart.ply", "{out}", "--close", "--resolution", "32"],
     "its 2 parts are each smaller than a voxel"),
    (["denoise", "{root}/smallfar.ply", "{out}.stl"], "STL stores coordinates in single precision"),
    # memory: refused before allocating, with advice that names the cause
    (["denoise", "{in}", "{out}", "--resolution", "4096"], "GiB is available; lower --resolution"),
    (["denoise", "{in}", "{out}", "--resolution", "64", "--threshold", "9000"],
     "the padding of 4502 voxels on each side makes most of it; lower --threshold"),
    (["denoise", "{in}", "{out}", "--resolution", "16", "--padding", "4000"], "lower --padding"),
    (["noise", "{in}", "{out}", "--resolution", "4096"], "GiB is available; lower --resolution"),
    (["noise", "{in}", "{out}", "--resolution", "32", "--h", "1000", "--r", "1000"], "lower --h and --r"),
    # scripts
    (["run-script", "{root}/writes.mlx", "{in}", "{out}"], "reads or writes files; not allowed in scripts"),
    (["run-script", "{root}/sketchfab.mlx", "{in}", "{out}"], "reads or writes files; not allowed in scripts"),
    (["run-script", "{root}/notxml.mlx", "{in}", "{out}"], "malformed filter script XML"),
    (["run-script", "{root}/unknown.mlx", "{in}", "{out}"], "'No Such Filter': unknown filter"),
    (["run-script", "{root}/entity.mlx", "{in}", "{out}"], "the DOCTYPE declares an internal subset"),
    (["run-script", "{root}/badvalue.mlx", "{in}", "{out}"], "threshold must be a number in"),
    (["run-script", "{root}/missing.mlx", "{in}", "{out}"], "no such filter script"),
    (["run-script", "{script}", "{in}", "{script}"], "refusing to overwrite the script file"),
    (["run-script", "{script}", "{in}", "{out}.txt"], "unsupported format 'txt'"),
    (["export-script", "denoise", "{out}.txt"], "ends in .mlx"),
    (["export-script", "denoise", "{out}.mlx", "--k", "-2"], "k must be a number in [0, 100]"),
    (["filters", "No Such Filter"], "no filter 'No Such Filter'"),
    # volumes, point clouds, batches
    (["denoise", "{root}/labels.npy", "{out}.npy"], "holds 3 values, not a mask: choose the shape with --label"),
    (["denoise", "{root}/labels.npy", "{out}.npy", "--label", "9"], "label 9 selects no voxel"),
    (["denoise", "{root}/labels.npy", "{out}.npy", "--label", "1", "--iso", "2"], "not allowed with argument"),
    (["denoise", "{root}/labels.npy", "{out}.npy", "--spacing", "0", "1", "1"], "spacing must be three numbers"),
    (["denoise", "{root}/labels.npy", "{out}.npy", "--label", "1", "--save-skeleton", "{out}"],
     "--save-skeleton needs a mesh input"),
    (["denoise", "{root}/broken.nii.gz", "{out}.nii.gz"], "malformed NIFTI file"),
    (["denoise", "{in}", "{out}.nii.gz"], "a mesh input gives a mesh output"),
    (["denoise", "{in}", "{out}", "--points"], "moved points need a point cloud input"),
    (["denoise", "{root}/sparse.pcd", "{out}"], "is too sparse"),
    (["denoise", "{in}", "{out}", "--label", "2"],
     "--label, --iso and --spacing are for volume inputs"),
    (["batch", "{root}/missing.ply", "--out", "{out}.d"], "no such file or folder"),
    (["batch", "{in}", "--out", "{out}.d", "--workers", "0"], "must be an integer in [1, 1024]"),
    (["batch", "{in}", "--out", "{root}/afile"], "exists and is not a folder"),
    (["batch", "{in}", "--out", "{out}.d", "--k", "nan"], "k must be a number in [0, 100]"),
    # comparison configurations
    (["compare", "{root}/type.toml", "--out", "{out}.d"], "case: must be a list of [[case]] tables, got int"),
    (["compare", "{root}/noisep.toml", "--out", "{out}.d"], "case 1 (c): noise: p must be a number"),
    (["compare", "{root}/jobs.toml", "--out", "{out}.d"], "jobs must be a positive integer"),
    (["compare", "{root}/kind.toml", "--out", "{out}.d"], "kind must be one of"),
    (["compare", "{root}/failing.toml", "--out", "{out}.d", "--quiet"], "garbage.obj: malformed OBJ file"),
    # round 2: faces that index no vertex, files that pull in others, headers that claim too much
    (["denoise", "{root}/outofrange.ply", "{out}"], "a face refers to vertex 99, and the mesh has 8"),
    (["denoise", "{root}/negative.ply", "{out}"], "a face refers to vertex -1"),
    (["denoise", "{root}/outofrange-binary.ply", "{out}"], "a face refers to vertex 1000"),
    (["noise", "{root}/outofrange.ply", "{out}"], "a face refers to vertex 99"),
    (["denoise", "{root}/elsewhere.nrrd", "{out}.nrrd"], "lies outside the header's folder"),
    (["denoise", "{root}/passwd.nrrd", "{out}.nrrd"], "lies outside the header's folder"),
    (["denoise", "{root}/linked.nrrd", "{out}.nrrd"], "lies outside the header's folder"),
    (["denoise", "{root}/huge.nii", "{out}.nii"], "the header claims a 2000x2000x2000 volume"),
    (["denoise", "{root}/nanlabels.npy", "{out}.npy"], "holds 3 values and NaN voxels, not a mask"),
    (["denoise", "{root}/labels.npy", "{out}.npy", "--label", "1", "--close"], "--output-mesh is for mesh inputs"),
    (["denoise", "{root}/beyondsingle.xyz", "{out}"], "numbers too large for the reader"),
    (["denoise", "{root}/hugespacing.vti", "{out}.vti"], "the voxel-to-world matrix is singular or not finite"),
    (["denoise", "{root}/code999.nii", "{out}.nii"], "malformed NIFTI file (data code 999 not recognized)"),
    (["denoise", "{root}/notimage.vti", "{out}.vti"], "malformed VTI file (not VTK XML image data)"),
    (["denoise", "{root}/flat.xyz", "{out}"], "lies in a plane (a flat scan)"),
    (["denoise", "{root}/line.xyz", "{out}"], "lies on a line"),
    (["run-script", "{root}/encoding.mlx", "{in}", "{out}"], "(its encoding: unknown encoding: klingon)"),
    (["compare", "{root}/cases.toml", "--out", "{out}.d"], "case names 'Cube' and 'cube!' give one file name"),
    (["compare", "{root}/methods.toml", "--out", "{out}.d"], "method names 'Clean' and 'clean?' give one file"),
    (["compare", "{root}/noisyname.toml", "--out", "{out}.d"], "method names the noisy input's mesh and"),
    (["compare", "--out", ""], "--out: the output folder's name is empty"),
    (["batch", "{in}", "--out", "{out}.d", "--scheduler", "notanaddress"], "--scheduler notanaddress: cannot connect"),
    (["batch", "{in}", "--out", "{root}/summaryfolder"], "summary.csv: is a folder"),
    (["denoise", "{root}/new\nline.ply", "{out}"], "new\\nline.ply: no such file"),
    (["denoise", "{in}", "{dir}/" + "x" * 300 + ".ply"], "file name too long writing"),
    # round 3: what the readers took silently, and messages that named the wrong cause
    (["denoise", "{root}/cut.vti", "{out}.vti"], "the VTI file is truncated (it does not end with </VTKFile>)"),
    (["denoise", "{root}/nanspacing.vti", "{out}.vti"], 'malformed VTI file (Spacing="nan 1 1" is not 3 finite'),
    (["denoise", "{root}/badorigin.vti", "{out}.vti"], 'malformed VTI file (Origin="0 x 0" is not 3 finite'),
    (["denoise", "{root}/smallpiece.vti", "{out}.vti"], "holds a piece of extent 0 5 0 5 0 5, not one piece of"),
    (["denoise", "{root}/faraway.vti", "{out}.vti"], "double precision cannot keep them apart"),
    (["denoise", "{root}/countlies.pts", "{out}"], "its first line declares 99999999 points, the file holds 1200"),
    (["denoise", "{root}/hugeheader.npy", "{out}.npy"], "the header claims a 100000x100000x100000 volume"),
    (["denoise", "{root}/nandirection.nrrd", "{out}.nrrd"], "its space directions (nan 0 0; 0 1 0; 0 0 1) are not"),
    (["denoise", "{root}/pixdim.nii", "{out}.nii"], "pixdim.nii: its voxels measure 1e+30 x 1 x 1 world units"),
    (["denoise", "{root}/labels.npy", "{out}.npy", "--label", "1", "--spacing", "1e-300", "1", "1"],
     "spacing must be three numbers in [1e-06, 1e+06], got 1e-300 1 1"),
    (["denoise", "{root}/labels.npy", "{out}.npy", "--label", "1", "--spacing", "1", "1", "2000"],
     "the volume spans 6000 voxels (its 1 x 1 x 2000 voxels made cubic); a grid holds at most 4096"),
    (["denoise", "{root}/pipe.npy", "{out}.npy"], "is not a regular file (a pipe, device or socket)"),
    (["export-script", "denoise", "{dir}/" + "x" * 300 + ".mlx"], "file name too long writing"),
]


def _script(filter_name, params=""):
    return (f'<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name="{filter_name}">\n{params} </filter>\n'
            '</FilterScript>\n')


def _config(case, method='name = "s"\nkind = "skelfilter"', run=""):
    return f"{run}\n[[case]]\n{case}\n[[method]]\n{method}\n"


BOX_OBJ = trimesh.creation.box().export(file_type="obj")
BOX_PLY = "".join(trimesh.creation.box().export(file_type="ply", encoding="ascii").decode())

# Files the cases read, by name; {root} is the folder they are in.
FILES = {
    "s.mlx": SCRIPT,
    "afile": "x",
    "objtext.stl": BOX_OBJ,
    "falsecount.stl": b"\0" * 80 + np.uint32(1000).tobytes() + np.zeros(12, np.float32).tobytes() + b"\0\0",
    "morevert.ply": BOX_PLY.replace("element vertex 8", "element vertex 50"),
    "garbage.obj": "hello world\n",
    "empty.off": "",
    "short.off": "OFF\n3 1 0\n0 0 0\n1 0 0\n",
    "nan.obj": "v 0 0 0\nv 1 0 0\nv nan 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n",
    "point.obj": "v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n",
    "writes.mlx": _script("Save Snapshot", '  <Param name="imagefilename" type="RichString" value="{root}/x.png"/>\n'),
    "sketchfab.mlx": _script("export_mesh_to_sketchfab"),
    "notxml.mlx": "this is not xml <",
    "unknown.mlx": _script("No Such Filter"),
    "entity.mlx": '<?xml version="1.0"?>\n<!DOCTYPE x [<!ENTITY e SYSTEM "file:///etc/passwd">]>\n'
                  '<FilterScript><filter name="&e;"/></FilterScript>\n',
    "badvalue.mlx": _script("Skeleton Saliency Denoise",
                            '  <Param name="threshold" type="RichFloat" value="1e30"/>\n'),
    "type.toml": "case = 3\nmethod = 'x'\n",
    "noisep.toml": _config('name = "c"\nmodel = "cube"\nnoise = {p = "abc"}'),
    "jobs.toml": _config('name = "c"\nmodel = "cube"', run="[run]\njobs = 0"),
    "kind.toml": _config('name = "c"\nmodel = "cube"', method='name = "s"\nkind = "magic"'),
    "failing.toml": _config('name = "c"\nnoisy = "garbage.obj"\nclean = "cube.ply"'),
    "outofrange.ply": BOX_PLY.replace("\n3 1 3 0\n", "\n3 1 3 99\n", 1),
    "negative.ply": BOX_PLY.replace("\n3 1 3 0\n", "\n3 1 3 -1\n", 1),
    "elsewhere.nrrd": "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: ../secret.raw\n\n",
    "passwd.nrrd": "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\nbyte skip: -1\n"
                   "data file: /etc/passwd\n\n",
    "linked.nrrd": "NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nencoding: raw\ndata file: link.raw\n\n",
    "encoding.mlx": '<?xml version="1.0" encoding="klingon"?>\n' + SCRIPT.split("\n", 1)[1],
    "cases.toml": _config('name = "Cube"\nmodel = "cube"\n[[case]]\nname = "cube!"\nmodel = "cube"'),
    "methods.toml": _config('name = "c"\nmodel = "cube"', method='name = "Clean"\nkind = "skelfilter"\n'
                            '[[method]]\nname = "clean?"\nkind = "skelfilter"'),
    "noisyname.toml": _config('name = "c"\nmodel = "cube"', method='name = "Input Noisy"\nkind = "skelfilter"'),
}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("bad")
    trimesh.creation.box().export(root / "cube.ply")
    for name, content in FILES.items():
        if isinstance(content, str):
            (root / name).write_text(content.replace("{root}", str(root)))
        else:
            (root / name).write_bytes(content)
    far = trimesh.creation.box()
    trimesh.util.concatenate([far, far.copy().apply_translation((1e4, 0, 0))]).export(root / "apart.ply")
    small_far = trimesh.creation.box()
    small_far.vertices = small_far.vertices * 1e-3 + 1e9
    mesh_files.save_mesh(small_far, root / "smallfar.ply")
    (root / "adir").mkdir()
    (root / "adir.ply").mkdir()
    np.save(root / "labels.npy", np.arange(27).reshape(3, 3, 3) % 3)
    (root / "broken.nii.gz").write_bytes(b"\x1f\x8b not really gzip")
    faces = trimesh.creation.box().faces.copy()
    faces[0, 2] = 1000
    (root / "outofrange-binary.ply").write_bytes(trimesh.exchange.ply.export_ply(
        trimesh.Trimesh(trimesh.creation.box().vertices, faces, process=False, validate=False)))
    (root.parent / "secret.raw").write_bytes(b"secret!!")
    (root / "link.raw").symlink_to(root.parent / "secret.raw")
    huge = nibabel.Nifti1Image(np.zeros((2, 2, 2), np.uint8), np.eye(4))
    huge.header.set_data_shape((2000, 2000, 2000))
    (root / "huge.nii").write_bytes(huge.header.binaryblock + b"\0" * 4 + b"\0" * 64)
    code999 = bytearray(nibabel.Nifti1Image(np.ones((4, 4, 4), np.uint8), np.eye(4)).to_bytes())
    code999[70:72] = (999).to_bytes(2, "little")  # the datatype field: no type nibabel knows (it logs first)
    (root / "code999.nii").write_bytes(bytes(code999))
    beyond_single = np.random.default_rng(0).random((1200, 3))
    beyond_single[5] = 1e39
    np.savetxt(root / "beyondsingle.xyz", beyond_single)
    import pyvista

    huge_spacing = pyvista.ImageData(dimensions=(6, 6, 6), spacing=(1e300, 1.0, 1.0))
    huge_spacing.point_data["mask"] = np.ones(216, dtype=np.uint8)
    huge_spacing.save(root / "hugespacing.vti")
    write_vti = huge_spacing.copy()
    write_vti.spacing = (1.0, 1.0, 1.0)
    write_vti.save(root / "whole.vti")
    whole = (root / "whole.vti").read_bytes()
    (root / "cut.vti").write_bytes(whole[:len(whole) // 2])
    (root / "nanspacing.vti").write_bytes(whole.replace(b'Spacing="1 1 1"', b'Spacing="nan 1 1"'))
    (root / "badorigin.vti").write_bytes(whole.replace(b'Origin="0 0 0"', b'Origin="0 x 0"'))
    (root / "smallpiece.vti").write_bytes(whole.replace(b'WholeExtent="0 5 0 5 0 5"', b'WholeExtent="0 9 0 5 0 5"'))
    (root / "faraway.vti").write_bytes(whole.replace(b'Origin="0 0 0"', b'Origin="1e17 0 0"'))
    (root / "countlies.pts").write_text("99999999\n" + "".join(f"{x} {y} {z}\n" for x, y, z in beyond_single))
    with open(root / "hugeheader.npy", "wb") as f:
        np.lib.format.write_array_header_1_0(f, {"descr": "|u1", "fortran_order": False,
                                                 "shape": (100000, 100000, 100000)})
        f.write(b"\0" * 64)
    (root / "nandirection.nrrd").write_bytes(b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 2 2 2\nspace: RAS\n"
                                             b"space directions: (nan,0,0) (0,1,0) (0,0,1)\nencoding: raw\n\n"
                                             + b"\1" * 8)
    pixdim = nibabel.Nifti1Image(np.ones((4, 4, 4), np.uint8), None)
    pixdim.header.set_zooms((1e30, 1.0, 1.0))
    pixdim.header.set_qform(None, code=0)
    pixdim.header.set_sform(None, code=0)
    (root / "pixdim.nii").write_bytes(pixdim.to_bytes())
    os.mkfifo(root / "pipe.npy")
    (root / "notimage.vti").write_text('<?xml version="1.0"?>\n<VTKFile type="PolyData"></VTKFile>\n')
    np.save(root / "nanlabels.npy", np.where(np.arange(27) < 3, np.nan, np.arange(27) % 3).reshape(3, 3, 3))
    sphere = trimesh.creation.icosphere(4).vertices
    np.savetxt(root / "flat.xyz", sphere * (1, 1, 0))
    np.savetxt(root / "line.xyz", np.outer(np.linspace(0, 1, 3000), (1, 2, 3)))
    (root / "summaryfolder" / "summary.csv").mkdir(parents=True)
    (root / "sparse.pcd").write_text("VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\n"
                                     "HEIGHT 1\nPOINTS 3\nDATA ascii\n0 0 0\n1 0 0\n0 1 0\n")
    return root


def digest(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


@pytest.mark.parametrize("args, message", CASES,
                         ids=[" ".join(a.replace("{root}/", "") for a in args) for args, _ in CASES])
def test_bad_input_gives_one_line_and_exit_2(files, tmp_path, args, message):
    names = {"in": files / "cube.ply", "out": tmp_path / "out.ply", "dir": files / "adir", "file": files / "afile",
             "script": files / "s.mlx", "root": files}
    argv = [a.format(**{k: str(v) for k, v in names.items()}) for a in args]
    before = {p.name: digest(p) for p in files.iterdir() if p.is_file()}
    r = subprocess.run([sys.executable, "-m", "skelfilter.cli", *argv], capture_output=True, text=True, timeout=300)
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert r.returncode == 2 and len(lines) == 1 and lines[0].startswith("skelfilter: error:"), r.stderr
    assert message in lines[0]
    assert {p: digest(files / p) for p in before} == before
    assert os.listdir(tmp_path) == [] and os.listdir(files / "adir") == [] and os.listdir(files / "adir.ply") == []
    assert sorted(p.name for p in files.iterdir() if p.is_file()) == sorted(before)


# The input files of the corpus, through the Python API and in a batch (where one bad file becomes
# its row's error and never stops the others).
BAD_FILES = {
    "outofrange.ply": "a face refers to vertex 99", "negative.ply": "a face refers to vertex -1",
    "outofrange-binary.ply": "a face refers to vertex 1000", "elsewhere.nrrd": "lies outside the header's folder",
    "passwd.nrrd": "lies outside the header's folder", "huge.nii": "the header claims a 2000x2000x2000 volume",
    "nanlabels.npy": "holds 3 values and NaN voxels", "flat.xyz": "lies in a plane",
    "garbage.obj": "malformed OBJ file", "nan.obj": "NaN or infinity", "sparse.pcd": "is too sparse",
}


@pytest.mark.parametrize("name", sorted(BAD_FILES))
def test_bad_files_through_the_python_api(files, tmp_path, name):
    from skelfilter import denoise_file

    before = digest(files / name)
    out = tmp_path / ("out" + name[name.index("."):])
    with pytest.raises(InputError, match=BAD_FILES[name].replace("(", r"\(")):
        denoise_file(files / name, out if not name.endswith((".xyz", ".pcd")) else tmp_path / "out.ply",
                     DenoiseParams())
    assert digest(files / name) == before and os.listdir(tmp_path) == []


def test_bad_files_in_a_batch_are_their_rows_errors(files, tmp_path):
    import csv

    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "skelfilter.cli", "batch", *(str(files / n) for n in BAD_FILES),
                        "--out", str(out), "--workers", "1"], capture_output=True, text=True, timeout=600)
    lines = [line for line in r.stderr.splitlines() if line.startswith("skelfilter:")]
    assert r.returncode == 1 and lines[0] == (f"skelfilter: 0 denoised, 0 skipped (output there), {len(BAD_FILES)} "
                                              f"failed; see {out / 'summary.csv'}"), r.stderr
    assert len(lines) == 2 and lines[1].startswith(f"skelfilter: error: {len(BAD_FILES)} of {len(BAD_FILES)} files "
                                                   f"failed, the first {files}/"), r.stderr
    assert "Traceback" not in r.stderr
    with open(out / "summary.csv", newline="") as f:
        rows = {os.path.basename(row["input"]): row for row in csv.DictReader(f)}
    for name, message in BAD_FILES.items():
        assert rows[name]["status"] == "failed" and message in rows[name]["error"], rows[name]
    assert sorted(os.listdir(out)) == ["summary.csv", "summary.json"]


@pytest.mark.parametrize("extra, message", [
    (["--save-skeleton", "{out}"], "refusing to overwrite the output file"),
    (["--save-skeleton", "{in}"], "refusing to overwrite the input file"),
    (["--save-skeleton", "{tmp}/missing/s.ply"], "output folder does not exist"),
    (["--save-skeleton", "{tmp}/s.obj"], "unsupported format 'obj' (use ply)"),
])
def test_output_paths_are_checked_before_computing(files, tmp_path, extra, message):
    names = {"in": str(files / "cube.ply"), "out": str(tmp_path / "out.ply"), "tmp": str(tmp_path)}
    argv = ["denoise", names["in"], names["out"], "--output-mesh", "closed", "--resolution", "32"]
    r = subprocess.run([sys.executable, "-m", "skelfilter.cli", *argv, *[a.format(**names) for a in extra]],
                       capture_output=True, text=True, timeout=300)
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert r.returncode == 2 and len(lines) == 1 and message in lines[0], r.stderr
    assert os.listdir(tmp_path) == []


def _cube():
    return trimesh.creation.box()


def _meshset_call(name, **params):
    import pymeshlab

    from skelfilter.meshlab import meshset

    meshset.register()
    ms = pymeshlab.MeshSet()
    cube = _cube()
    ms.add_mesh(pymeshlab.Mesh(cube.vertices, cube.faces))
    getattr(ms, name)(**params)


API_CASES = [
    (lambda m: mesh_pipeline.denoise_mesh(m, k=float("nan")), ParameterError, r"k must be a number in \[0, 100\]"),
    (lambda m: mesh_pipeline.denoise_mesh(m, resolution="64"), ParameterError, "resolution must be an integer"),
    (lambda m: mesh_pipeline.denoise_mesh(m, resolution=2**63), ParameterError, r"resolution must be an integer in"),
    (lambda m: mesh_pipeline.denoise_mesh(m, threshold=float("inf")), ParameterError, "threshold must be a number"),
    (lambda m: mesh_pipeline.denoise_mesh(m, nosuch=1), ParameterError, "unknown parameter nosuch"),
    (lambda m: mesh_pipeline.denoise_mesh(m, output_mesh="cube"), ParameterError, "output_mesh must be one of"),
    (lambda m: mesh_pipeline.denoise_mesh(m, preset="fast"), ParameterError, "preset must be one of"),
    (lambda m: mesh_pipeline.denoise_mesh(m, resolution=4096), ResourceError, "GiB is available"),
    (lambda m: mesh_pipeline.denoise_mesh(str(m)), InputError,
     r"expected a trimesh.Trimesh or a \(vertices, faces\) pair, got str"),
    (lambda m: mesh_pipeline.denoise_mesh(trimesh.Trimesh()), InputError, "the mesh is empty"),
    (lambda m: mesh_pipeline.denoise_mesh(trimesh.Trimesh(m.vertices * np.nan, m.faces, process=False)), InputError,
     "NaN"),
    (lambda m: mesh_pipeline.noisy_mesh(m, l=10**9), ParameterError, r"l must be an integer in \[1, 100000\]"),
    (lambda m: mesh_pipeline.noisy_mesh(m, q=1), ParameterError, "unknown parameter q"),
    (lambda m: mesh_pipeline.noisy_mesh(m, seed=-1), ParameterError, "seed must be an integer in"),
    (lambda m: pipeline.denoise_volume(np.zeros((4, 4))), InputError, "a volume must be 3-D"),
    (lambda m: pipeline.denoise_volume(np.zeros((8, 8, 8))), InputError, "the volume is empty"),
    (lambda m: DenoiseParams(k=-1), ParameterError, r"k must be a number in \[0, 100\]"),
    (lambda m: NoiseParams(r=float("nan")), ParameterError, "r must be a number in"),
    (lambda m: _meshset_call("apply_skeleton_saliency_denoise", threshold=-1.0), ParameterError,
     "threshold must be a number in"),
    (lambda m: _meshset_call("apply_skeleton_noise", l=0), ParameterError, "l must be an integer in"),
    (lambda m: _meshset_call("apply_skeleton_saliency_denoise", treshold=9.0), ParameterError, "treshold"),
    (lambda m: _empty_meshset_call(), InputError, r"the MeshSet is empty: add a mesh first"),
    (lambda m: mesh_pipeline.denoise_mesh((m.vertices, m.faces + 0.5)), InputError,
     "face indices must be whole numbers, got 1.5"),
    (lambda m: mesh_pipeline.denoise_mesh((m.vertices, m.faces[:, :2])), InputError, r"faces of shape \(m, 3\)"),
    (lambda m: mesh_pipeline.denoise_mesh((m.vertices, m.faces > 0)), InputError, "face indices must be integers"),
    (lambda m: mesh_pipeline.denoise_mesh(m, resolution=np.bool_(True)), ParameterError, "must be an integer"),
    (lambda m: mesh_pipeline.denoise_mesh(m, "default"), ParameterError,
     r"params must be a DenoiseParams or None, got str \(a preset by name: preset='default'\)"),
    (lambda m: mesh_pipeline.noisy_mesh(m, {"h": 3}), ParameterError, "params must be a NoiseParams or None, got dict"),
    (lambda m: pipeline.denoise_volume(np.pad(np.ones((8, 8, 8), bool), 4), spacing="1 1 1"), ParameterError,
     r"spacing must be three numbers in \[1e-06, 1e\+06\], got '1 1 1'"),
    (lambda m: mesh_pipeline.denoise_mesh(trimesh.Trimesh(m.vertices[:, :2], m.faces, process=False)), InputError,
     r"vertices of shape \(n, 3\) expected, got \(8, 2\)"),
    (lambda m: _out_of_memory("skelfilter.mesh.pipeline._denoise_unit",
                              lambda: mesh_pipeline.denoise_mesh(m, resolution=32)),
     ResourceError, "out of memory denoising a mesh of 12 faces; lower `resolution`"),
    (lambda m: _out_of_memory("skelfilter.core.pipeline._fine_pass_then_stages",
                              lambda: pipeline.denoise_volume(np.ones((8, 8, 8), bool))),
     ResourceError, r"out of memory denoising a volume of shape \(8, 8, 8\)"),
]


def _empty_meshset_call():
    import pymeshlab

    from skelfilter.meshlab import meshset

    meshset.apply_skeleton_saliency_denoise(pymeshlab.MeshSet())


def _out_of_memory(name, call):
    """``call`` with the function ``name`` failing as an allocation does when memory runs out."""
    import importlib
    from unittest import mock

    module, function = name.rsplit(".", 1)

    def exhausted(*args, **kwargs):
        raise MemoryError()

    with mock.patch.object(importlib.import_module(module), function, exhausted):
        call()


def test_numpy_numbers_and_whole_float_indices_are_taken():
    cube = _cube()
    out = mesh_pipeline.denoise_mesh((cube.vertices, cube.faces.astype(float)), resolution=np.int64(32))
    assert isinstance(out, trimesh.Trimesh) and len(out.faces) > 0
    assert type(DenoiseParams(resolution=np.int64(32), threshold=np.float32(3)).resolution) is int


def test_a_mesh_too_large_for_the_memory_is_named_as_the_cause():
    from skelfilter.runtime.memory import check_grid_fits

    with pytest.raises(ResourceError, match="the mesh's 2000000 faces need about .* simplify the mesh"):
        check_grid_fits((64, 64, 64), available=2**30, faces=2_000_000)
    with pytest.raises(ResourceError, match="lower `resolution`"):
        check_grid_fits((1024, 1024, 1024), available=2**30, faces=2_000)


@pytest.mark.parametrize("call, error, message", API_CASES, ids=[f"api{i}" for i in range(len(API_CASES))])
def test_python_api_refuses_with_one_error_and_leaves_the_mesh_alone(call, error, message):
    mesh = _cube()
    vertices, faces = mesh.vertices.copy(), mesh.faces.copy()
    with pytest.raises(error, match=message):
        call(mesh)
    assert np.array_equal(mesh.vertices, vertices) and np.array_equal(mesh.faces, faces)


def test_script_that_writes_files_is_refused_by_the_python_api(files):
    before = digest(files / "cube.ply")
    with pytest.raises(InputError, match="reads or writes files; not allowed in scripts"):
        run_filter_script(_cube(), str(files / "writes.mlx"))
    assert not (files / "x.png").exists() and digest(files / "cube.ply") == before


def _limit_memory(megabytes):
    def apply():
        resource.setrlimit(resource.RLIMIT_AS, (megabytes * 2**20, megabytes * 2**20))
    return apply


def test_a_process_memory_limit_is_respected(files, tmp_path):
    """``ulimit -v``: the estimate reads the limit, so a grid the machine could hold is refused at once."""
    r = subprocess.run([sys.executable, "-m", "skelfilter.cli", "denoise", str(files / "cube.ply"),
                        str(tmp_path / "out.ply"), "--resolution", "1024"], capture_output=True, text=True,
                       timeout=300, preexec_fn=_limit_memory(4096))
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert r.returncode == 2 and len(lines) == 1 and "GiB is available" in lines[0], r.stderr
    assert float(lines[0].split("only ")[1].split(" GiB")[0]) < 4.0
    assert os.listdir(tmp_path) == []


def test_a_deleted_current_folder_is_named_as_the_cause(files, tmp_path):
    gone = tmp_path / "gone"
    gone.mkdir()
    r = subprocess.run(["bash", "-c", f'cd "{gone}" && rmdir "{gone}" && "{sys.executable}" -m skelfilter.cli '
                                      f'denoise "{files / "cube.ply"}" out.ply'], capture_output=True, text=True,
                       timeout=300)
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert r.returncode == 2 and lines == ["skelfilter: error: the current folder no longer exists (it was deleted "
                                           "or moved): run from an existing folder, or give absolute paths"], r.stderr
    assert os.listdir(tmp_path) == []


def test_library_warnings_are_one_line_or_silent(capsys):
    import logging
    import warnings

    from skelfilter.cli import commands

    with warnings.catch_warnings():
        saved = warnings.showwarning
        try:
            for quiet, expected in ((False, "skelfilter: warning: a library complains\n" * 2), (True, "")):
                commands._route_library_messages(quiet)
                warnings.warn("a library\n complains", UserWarning, stacklevel=1)
                logging.getLogger("trimesh").warning("a library complains")
                assert capsys.readouterr().err == expected
        finally:
            warnings.showwarning = saved
            logging.basicConfig(level=logging.WARNING, force=True)


def test_outputs_follow_the_umask(files, tmp_path):
    old = os.umask(0o027)
    try:
        mesh_files.save_mesh(_cube(), tmp_path / "new.ply")
        assert os.stat(tmp_path / "new.ply").st_mode & 0o777 == 0o640
        os.chmod(tmp_path / "new.ply", 0o604)
        mesh_files.save_mesh(_cube(), tmp_path / "new.ply")  # a replaced file keeps its mode
        assert os.stat(tmp_path / "new.ply").st_mode & 0o777 == 0o604
    finally:
        os.umask(old)


@pytest.mark.parametrize("layout", ["tabs", "comments at line ends", "both"])
def test_an_obj_with_tabs_or_comments_at_line_ends_is_read(tmp_path, layout):
    """Both are common in hand-written and exported OBJ files; trimesh's reader took neither (a raw
    NumPy message, or no triangles)."""
    tetra = trimesh.creation.icosphere(1)
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in tetra.vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in tetra.faces]
    if layout != "tabs":
        lines = [line + "  # a note" for line in lines]
    text = "# an icosphere\n" + "\n".join(lines) + "\n"
    if layout != "comments at line ends":
        text = text.replace(" ", "\t")
    path = tmp_path / "shape.obj"
    path.write_text(text)
    mesh = mesh_files.load_mesh(path)
    assert np.allclose(mesh.vertices, tetra.vertices, atol=1e-6) and np.array_equal(mesh.faces, tetra.faces)
