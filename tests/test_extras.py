"""Optional dependencies: each comes with an extra, and a missing one is refused in one line."""

import os
import subprocess
import sys
import tomllib

import pytest

from skelfilter.runtime import extras
from skelfilter.runtime.extras import EXTRA_OF, MissingExtra, need

ROOT = os.path.join(os.path.dirname(__file__), "..")
# The module each optional distribution installs.
MODULE_OF = {"pymeshlab": "pymeshlab", "nibabel": "nibabel", "pynrrd": "nrrd", "tifffile": "tifffile",
             "dask[distributed]": "dask", "meshlib": "meshlib", "pygel3d": "pygel3d", "pyvista": "pyvista",
             "Pillow": "PIL", "manifold3d": "manifold3d", "open3d": "open3d"}


def _extras():
    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        return tomllib.load(f)["project"]["optional-dependencies"]


def test_every_optional_module_comes_with_the_extra_it_names():
    declared = {}
    for extra, requirements in _extras().items():
        for requirement in requirements:
            name = requirement.split(">")[0].split("=")[0].strip()
            if name in MODULE_OF:
                declared.setdefault(MODULE_OF[name], set()).add(extra)
    declared.setdefault("distributed", set()).update(declared["dask"])  # dask[distributed]
    for module, extra in EXTRA_OF.items():
        assert extra in declared.get(module, ()), (module, extra)
    for module in extras.COMPARE_MODULES:
        assert "compare" in declared[module.split(".")[0]], module


def test_need_imports_an_installed_module():
    assert need("numpy", "anything").__name__ == "numpy"


def test_need_names_the_extra_of_a_missing_module(monkeypatch):
    monkeypatch.setitem(sys.modules, "pymeshlab", None)  # what an import finds for a missing module
    with pytest.raises(MissingExtra, match=r"^MeshLab's filters: pymeshlab is not installed; .*"
                                           r"pip install 'skelfilter\[meshlab\]'$"):
        need("pymeshlab", "MeshLab's filters")
    with pytest.raises(MissingExtra, match=r"skelfilter\[compare\]"):
        need("pymeshlab", "skelfilter compare", extra="compare")


def test_a_volume_without_its_reader_is_no_malformed_file(monkeypatch, tmp_path):
    from skelfilter.io import volume_files

    (tmp_path / "v.nii").write_bytes(b"\0" * 348)
    monkeypatch.setitem(sys.modules, "nibabel", None)
    with pytest.raises(MissingExtra, match=r"^NIfTI volumes: nibabel is not installed"):
        volume_files.load_volume(tmp_path / "v.nii")


def test_a_broken_install_is_not_taken_for_a_missing_extra(monkeypatch):
    def fail(name, *args, **kwargs):
        raise ModuleNotFoundError("No module named 'libsomething'", name="libsomething")
    monkeypatch.setattr(extras.importlib, "import_module", fail)
    with pytest.raises(ModuleNotFoundError, match="libsomething"):
        need("pymeshlab", "MeshLab's filters")


@pytest.mark.parametrize("argv, blocked, extra", [
    (["run-script", os.path.join(ROOT, "meshlab_scripts", "mixed_example.mlx"), "IN.ply", "OUT.ply"],
     ["pymeshlab"], "meshlab"),
    (["denoise", "IN.npy", "OUT.nii.gz"], ["nibabel"], "volumes"),
    (["compare", "--out", "OUT"], ["meshlib", "meshlib.mrmeshpy"], "compare"),
    (["batch", "IN.ply", "--out", "OUT"], ["distributed"], "batch"),
    (["denoise", "IN.xyz", "OUT.ply"], ["open3d"], "clouds"),
])
def test_the_cli_refuses_a_missing_extra_in_one_line(tmp_path, argv, blocked, extra):
    import numpy as np
    import trimesh

    trimesh.creation.box().export(tmp_path / "IN.ply")
    volume = np.zeros((24, 24, 24), dtype=bool)
    volume[4:20, 4:20, 4:20] = True
    np.save(tmp_path / "IN.npy", volume)
    np.savetxt(tmp_path / "IN.xyz", np.random.default_rng(0).normal(size=(500, 3)))
    code = (f"import sys\nfor m in {blocked!r}: sys.modules[m] = None\n"
            f"from skelfilter.cli import main\nsys.argv = ['skelfilter', *{argv!r}]\nsys.exit(main())\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    lines = [line for line in r.stderr.splitlines() if line.startswith("skelfilter: error:")]
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    assert f"pip install 'skelfilter[{extra}]'" in lines[0]
    assert r.stderr.strip().splitlines()[-1] == lines[0]
    assert sorted(os.listdir(tmp_path)) == ["IN.npy", "IN.ply", "IN.xyz"]


@pytest.mark.parametrize("argv", [["denoise", "IN.ply", "OUT.ply", "--close", "--resolution", "48"],
                                  ["denoise", "NOISY.ply", "OUT.ply"], ["denoise", "IN.npy", "OUT.npy"]])
def test_meshes_and_volumes_need_no_extra(tmp_path, argv):
    """The core install (no open3d: it comes with the point clouds' extra) denoises meshes and volumes."""
    import numpy as np
    import trimesh

    trimesh.creation.box().export(tmp_path / "IN.ply")
    sphere = trimesh.creation.icosphere(4)
    sphere.vertices += np.random.default_rng(0).normal(0, 0.01, sphere.vertices.shape)
    sphere.export(tmp_path / "NOISY.ply")
    volume = np.zeros((24, 24, 24), dtype=bool)
    volume[4:20, 4:20, 4:20] = True
    np.save(tmp_path / "IN.npy", volume)
    code = ("import sys\nsys.modules['open3d'] = None\n"
            f"from skelfilter.cli import main\nsys.argv = ['skelfilter', *{argv!r}, '--quiet']\nsys.exit(main())\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stderr == "", r.stderr
    assert (tmp_path / argv[2]).exists()


def test_library_messages_name_parameters_and_the_cli_its_flags():
    from skelfilter.cli.commands import _in_cli_terms
    from skelfilter.errors import ResourceError
    from skelfilter.runtime.memory import check_grid_fits

    with pytest.raises(ResourceError, match=r"lower `resolution`$") as refused:
        check_grid_fits((4096, 4096, 4096), available=2**30)
    assert _in_cli_terms(str(refused.value)).endswith("lower --resolution")
    assert _in_cli_terms("`save_skeleton` needs a mesh input; `not_a_parameter` stays") == (
        "--save-skeleton needs a mesh input; `not_a_parameter` stays")


def test_runs_where_numba_can_write_no_cache():
    # a system install run by an account that can write neither beside the package nor in a home
    code = """
from numba.core import caching
caching.CacheImpl._locator_classes = []  # no folder numba could write its cache to
import numpy as np
from skelfilter.core import pipeline
volume = np.zeros((24, 24, 24), dtype=bool)
volume[6:18, 6:18, 6:18] = True
print(pipeline.denoise_volume(volume).mask.sum())
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert int(done.stdout.split()[-1]) == 12 ** 3
