"""A filter script is data from anyone: no MeshLab filter that reads or writes a file runs from one."""

import hashlib
import subprocess
import sys

import pytest
import trimesh

from skelfilter.errors import InputError
from skelfilter.meshlab import filter_catalogue, scripts


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "skelfilter.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=600)


def script(filter_name, params=""):
    return (f'<!DOCTYPE FilterScript>\n<FilterScript>\n <filter name="{filter_name}">\n{params} </filter>\n'
            "</FilterScript>\n")


def digest(path):
    return hashlib.sha256(open(path, "rb").read()).hexdigest()


@pytest.fixture(scope="module")
def mesh_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("in") / "cube.ply"
    trimesh.creation.box().export(path)
    return path


def test_the_nxs_build_attack_is_refused_and_the_input_survives(mesh_file, tmp_path):
    """The issue's six-line script: NXS Build pointed at the input mesh overwrote it (exit 0)."""
    before = digest(mesh_file)
    target = tmp_path / "written.nxs"
    params = (f'  <Param name="input_file" type="RichString" value="{mesh_file}"/>\n'
              f'  <Param name="output_file" type="RichString" value="{mesh_file}"/>\n')
    for name in ("NXS Build", "nxs_build"):
        path = tmp_path / "attack.mlx"
        path.write_text(script(name, params))
        r = run_cli("run-script", path, mesh_file, tmp_path / "out.ply")
        lines = [line for line in r.stderr.strip().splitlines() if line]
        assert r.returncode == 2 and len(lines) == 1, r.stderr
        assert lines[0] == (f"skelfilter: error: {path}:3: filter {name!r}: reads or writes files; "
                            "not allowed in scripts")
    assert digest(mesh_file) == before and not target.exists() and not (tmp_path / "out.ply").exists()


@pytest.mark.parametrize("pname", sorted(filter_catalogue.FILE_FILTERS))
def test_every_filter_touching_files_is_refused(pname, tmp_path):
    path = tmp_path / "s.mlx"
    path.write_text(script(pname))
    with pytest.raises(InputError, match="reads or writes files; not allowed in scripts"):
        scripts.read_script(path)


def test_every_pymeshlab_filter_with_a_file_parameter_is_refused():
    named = {f for f, params in filter_catalogue.parameter_lists().items()
             if any(k in p for p in params for k in ("file", "textname", "texturename"))}
    assert named and all(filter_catalogue.touches_files(f) for f in named)
    assert named <= filter_catalogue.FILE_FILTERS
    # and the ordinary ones still run
    for f in ("apply_coord_taubin_smoothing", "apply_coord_laplacian_smoothing", "set_mesh_name"):
        assert not filter_catalogue.touches_files(f)


def test_file_typed_parameters_are_refused(tmp_path):
    path = tmp_path / "s.mlx"
    path.write_text(script("Taubin Smooth", '  <Param name="lambda" type="RichSaveFile" value="/tmp/x"/>\n'))
    with pytest.raises(InputError, match="a file name .RichSaveFile.; not allowed in scripts"):
        scripts.read_script(path)
