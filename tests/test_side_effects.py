"""Library calls leave the process as they found it: the signal mask during and after a run, the
environment, matplotlib's pyplot (no backend chosen, no figure left)."""

import subprocess
import sys

CHECK = r'''
import os, signal, sys
import numpy as np
import trimesh
from skelfilter.core import pipeline, skeleton
from skelfilter.evaluation import figures
from skelfilter.mesh import pipeline as mesh_pipeline
from skelfilter.runtime.progress import Progress

masks = set()  # the signal masks seen inside the skeleton step
original = skeleton.ie_skeleton
def watched(*args):
    masks.add(frozenset(signal.pthread_sigmask(signal.SIG_BLOCK, [])))
    return original(*args)
skeleton.ie_skeleton = watched
shield = sys.argv[2] == "shield"

environment = dict(os.environ)
before = frozenset(signal.pthread_sigmask(signal.SIG_BLOCK, []))
volume = np.zeros((40, 40, 40), bool)
volume[8:32, 8:32, 8:32] = True
pipeline.denoise_volume(volume, progress=Progress(enabled=False, shield=shield) if shield else None)
box = trimesh.creation.box()
mesh_pipeline.denoise_mesh(box, resolution=32, progress=Progress(enabled=False, shield=shield) if shield else None)
figures.save_panels([box], ["box"], os.path.join(sys.argv[1], "box.png"))
assert masks and masks == {before}, (masks, before)
assert frozenset(signal.pthread_sigmask(signal.SIG_BLOCK, [])) == before
assert dict(os.environ) == environment
assert "matplotlib.pyplot" not in sys.modules
print("unchanged")
'''


def test_a_library_run_changes_no_process_wide_state(tmp_path):
    r = subprocess.run([sys.executable, "-c", CHECK, str(tmp_path), "library"], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0 and r.stdout.strip() == "unchanged", r.stderr[-2000:]
    assert (tmp_path / "box.png").stat().st_size > 0


def test_the_check_sees_the_shield_the_cli_asks_for(tmp_path):
    r = subprocess.run([sys.executable, "-c", CHECK, str(tmp_path), "shield"], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode != 0 and "AssertionError" in r.stderr
