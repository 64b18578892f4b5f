"""The comparison's output folder: what a run writes there, and what it may replace.

A run makes its report in a hidden folder inside the output folder and moves it out at the end.
It replaces only what an earlier run made there (the files its ``results.json`` lists) and refuses,
before anything is computed, when a name it needs is taken by anything else (a user's own folder
``cube/`` when a case is named ``cube``).
"""

import json
import os
import shutil

from skelfilter.errors import InputError
from skelfilter.evaluation.comparison.config import slug
from skelfilter.evaluation.comparison.report import PICTURES
from skelfilter.io.output_files import same_file
from skelfilter.runtime.signals import deferred

TABLES = ("results.json", "metrics.csv", "report.html", "report.md", "colour-scale.png", "sweep.png")
TOP_LEVEL = TABLES + tuple(f"grid-{kind}.png" for kind, _ in PICTURES)
NOISY_MESH = "input-noisy.ply"


def case_files(method_names):
    """The files of one case's folder for methods named ``method_names``."""
    files = [NOISY_MESH]
    for name in method_names:
        files += [f"{slug(name)}.ply"] + [f"{slug(name)}-{kind}.png" for kind, _ in PICTURES]
    return files


def planned(config):
    """What a run of ``config`` may write: top-level names, and each case folder's files."""
    methods = [m.name for m in config.methods]
    return TOP_LEVEL, {slug(case.name): case_files(methods) for case in config.cases}


def earlier_run(out_dir):
    """What the last run made in ``out_dir``, from its ``results.json``: top-level names, and each
    case folder's files (empty when there is no readable report)."""
    try:
        with open(os.path.join(out_dir, "results.json"), encoding="utf-8") as f:
            results = json.load(f)
        cases = {}
        for case in results["cases"]:
            folder = slug(case["name"])
            files = {NOISY_MESH}
            for method in case["methods"]:
                for path in [method.get("mesh"), *method.get("images", {}).values()]:
                    if path and os.path.dirname(path) == folder:
                        files.add(os.path.basename(path))
            cases[folder] = files
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return set(), {}
    return set(TOP_LEVEL), cases


def check_out_folder(config, out_dir):
    """Refuse a run that would replace what an earlier run did not make.

    Raises
    ------
    InputError
        The folder's name is empty, it is a file, or a name the run writes is taken by something
        else.
    """
    out_dir = str(out_dir)
    if not out_dir:
        raise InputError("the output folder's name is empty")
    if os.path.lexists(out_dir) and not os.path.isdir(out_dir):
        raise InputError(f"{out_dir}: exists and is not a folder")
    if not os.path.isdir(out_dir):
        return
    top, cases = planned(config)
    _check_inputs_apart(config, out_dir, top, cases)
    made_top, made_cases = earlier_run(out_dir)
    for name in top:
        if os.path.lexists(os.path.join(out_dir, name)) and name not in made_top:
            _refuse(out_dir, name)
    for folder, files in cases.items():
        path = os.path.join(out_dir, folder)
        if not os.path.lexists(path):
            continue
        if folder not in made_cases or os.path.islink(path) or not os.path.isdir(path):
            _refuse(out_dir, folder)
        for name in files:
            if os.path.lexists(os.path.join(path, name)) and name not in made_cases[folder]:
                _refuse(out_dir, os.path.join(folder, name))


def _check_inputs_apart(config, out_dir, top, cases):
    """No file the run reads (a case's meshes, a method's script) is one it writes."""
    writes = [os.path.join(out_dir, name) for name in top]
    writes += [os.path.join(out_dir, folder, name) for folder, names in cases.items() for name in names]
    reads = [p for c in config.cases for p in (c.model, c.noisy, c.clean) if p] + \
        [m.script for m in config.methods if m.script]
    for path in filter(os.path.exists, writes):
        for source in reads:
            if same_file(source, path):
                raise InputError(f"{path}: the comparison reads it ({source}) and would replace it; "
                                 "choose another --out")


def _refuse(out_dir, name):
    raise InputError(f"{os.path.join(out_dir, name)}: exists and was not made by an earlier skelfilter compare; "
                     "refusing to replace it (choose another --out, or move it)")


def move_in(work, out_dir):
    """Move a finished report from ``work`` into ``out_dir`` in one go (no interrupt in between):
    files onto their names, case folders whole, or file by file into the earlier run's folder."""
    with deferred():
        for name in os.listdir(work):
            source, target = os.path.join(work, name), os.path.join(out_dir, name)
            if os.path.isdir(source) and os.path.isdir(target) and not os.path.islink(target):
                for inner in os.listdir(source):
                    os.replace(os.path.join(source, inner), os.path.join(target, inner))
            else:
                os.replace(source, target)


def remove_made(out_dir, created, work):
    """After a failed or interrupted run: its hidden folder goes, and the output folder too if the
    run made it (nothing else was moved into it)."""
    with deferred():
        if work is not None:
            shutil.rmtree(work, ignore_errors=True)
        if created:
            shutil.rmtree(out_dir, ignore_errors=True)
