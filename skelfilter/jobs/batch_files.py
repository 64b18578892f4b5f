"""Which files a batch reads and where it writes: inputs from files, folders and patterns, one output
per input (beside the others, or mirroring their folders), checked before anything runs."""

import glob
import os

from skelfilter.errors import InputError
from skelfilter.io import formats, output_files
from skelfilter.jobs import denoise_file


def expand_inputs(inputs):
    """Files, folders and glob patterns (their supported files that are not hidden; folders are not
    recursed), as a list of unique paths.

    Raises
    ------
    InputError
        A path or pattern that names nothing, or no supported file at all.
    """
    found = []
    for item in inputs:
        item = str(item)
        if os.path.isdir(item):
            found += [os.path.join(item, name) for name in sorted(os.listdir(item))
                      if os.path.isfile(os.path.join(item, name)) and _supported(name)]
        elif os.path.isfile(item):
            found.append(item)
        elif glob.has_magic(item):
            matches = [p for p in sorted(glob.glob(item)) if os.path.isfile(p) and _supported(p)]
            if not matches:
                raise InputError(f"{item}: the pattern matches no file")
            found += matches
        else:
            raise InputError(f"{item}: no such file or folder")
    unique = list(dict.fromkeys(os.path.abspath(p) for p in found))
    if not unique:
        raise InputError("no input file of a supported kind")
    return unique


def _supported(name):
    """A file of a kind skelfilter reads, not hidden (a temporary output, a system file)."""
    if os.path.basename(name).startswith("."):
        return False
    try:
        formats.file_kind(name)
        return True
    except InputError:
        return False


def output_paths(inputs, out_dir, to=None, keep_tree=False):
    """Where each input's result goes: ``out_dir`` / its name (with the suffix ``to`` if given); with
    ``keep_tree``, ``out_dir`` / its path below the folder all inputs share.

    Raises
    ------
    InputError
        Two inputs that would write the same output.
    """
    root = os.path.commonpath([os.path.dirname(p) for p in inputs]) if keep_tree else None
    outputs, seen = [], {}
    for path in inputs:
        name = os.path.relpath(path, root) if keep_tree else os.path.basename(path)
        if to:
            name = name[: -len(output_files.file_suffix(name))] + "." + to.lstrip(".")
        out = os.path.abspath(os.path.join(out_dir, name))
        if out in seen:
            raise InputError(f"{path} and {seen[out]} would both write {out}; keep their folders under the "
                             "output folder (`keep_tree`, the CLI's --keep-tree), or put them in separate batches")
        seen[out] = path
        outputs.append(out)
    return outputs


def check_outputs(inputs, outputs):
    """Refuse, before anything runs, an output that is an input or that its input cannot become."""
    files = {_file_id(path): path for path in inputs}
    for path, out in zip(inputs, outputs):
        denoise_file.check_paths(path, out)
        if out in inputs or (os.path.exists(out) and _file_id(out) in files):
            raise InputError(f"{out}: refusing to overwrite an input file ({files.get(_file_id(out), out)})")


def make_folders(folders):
    """Create the missing ``folders`` (and their missing parents); returns those it created, deepest
    first, for `remove_empty`."""
    created = []
    for folder in sorted(set(folders)):
        missing = []
        while not os.path.isdir(folder):
            missing.append(folder)
            folder = os.path.dirname(folder)
        for folder in reversed(missing):
            try:
                os.mkdir(folder)
            except OSError as exc:
                remove_empty(sorted(created, key=len, reverse=True))
                raise output_files.write_failure(exc, folder) from None
            created.append(folder)
    return sorted(created, key=len, reverse=True)


def remove_empty(folders):
    for folder in folders:
        if os.path.isdir(folder) and not os.listdir(folder):
            os.rmdir(folder)


def _file_id(path):
    """Device and inode: one file under every name (a hard link, a bind mount, a symlinked folder)."""
    stat = os.stat(path)
    return stat.st_dev, stat.st_ino
