"""The README and docs/ as a user meets them: every link leads somewhere, every module or file they
name exists, and the Python examples that need no file of the user's run as written."""

import pathlib
import re
import runpy

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
# Examples that need a cluster of the user's are shown, not run here; the others run as written, in
# a folder holding the files they read (noisy.ply: a noisy sample).
NEEDS_THE_USER = ("dask_jobqueue", "/shared/")


def _blocks(page, language):
    return re.findall(rf"```{language}\n(.*?)```", page.read_text(), flags=re.S)


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_links_lead_somewhere(page):
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text()):
        if "://" not in target:
            assert (page.parent / target).exists(), f"{page.name}: broken link {target}"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_named_files_and_modules_exist(page):
    text = page.read_text()
    for path in set(re.findall(r"`((?:skelfilter|benchmarks|experiments|tests|meshlab_scripts|comparisons)/[\w/.-]+)`",
                               text)):
        assert (ROOT / path).exists(), f"{page.name} names {path}, which does not exist"
    for command in set(re.findall(r"python -m ((?:benchmarks|experiments)\.\w+)", text)):
        script = (ROOT / command.replace(".", "/")).with_suffix(".py")
        assert script.exists(), f"{page.name} runs {command}, which is no module"
    for module in set(re.findall(r"\bskelfilter(?:\.[a-z_]+)+", text)):
        parts = module.split(".")
        found = any((ROOT / "/".join(parts[:k])).with_suffix(".py").exists()
                    or (ROOT / "/".join(parts[:k]) / "__init__.py").exists() for k in (len(parts), len(parts) - 1))
        assert found, f"{page.name} names {module}, which is no module"


EXAMPLES = [(page, code) for page in PAGES for code in _blocks(page, "python")
            if not any(marker in code for marker in NEEDS_THE_USER)]


@pytest.mark.parametrize("page, code", EXAMPLES, ids=[p.name for p, _ in EXAMPLES])
def test_python_examples_run(page, code, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    if "noisy.ply" in code:
        from skelfilter import NoiseParams, noisy_mesh
        from skelfilter.io.mesh_files import load_mesh, save_mesh
        from skelfilter.io.samples import sample_path

        save_mesh(noisy_mesh(load_mesh(sample_path()), NoiseParams(resolution=48, seed=1))[0], tmp_path / "noisy.ply")
    script = tmp_path / "example.py"
    script.write_text(code)
    runpy.run_path(str(script), run_name="__main__")


def test_the_readme_is_short():
    assert len((ROOT / "README.md").read_text().splitlines()) < 250
