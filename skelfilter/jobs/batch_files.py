"""Which files a batch reads and where it writes: inputs from files, folders (subfolders included) and
patterns, one output per input (a folder's files mirroring its subfolders, or every input mirroring
its folder), checked before anything runs."""

import glob
import os

from skelfilter.errors import InputError
from skelfilter.io import formats, output_files
from skelfilter.jobs import denoise_file


def expand_inputs(inputs):
    """Files, folders and glob patterns as a list of unique paths (see `find_inputs`)."""
    return [path for path, _ in find_inputs(inputs)]


def find_inputs(inputs):
    """Files, folders and glob patterns, as unique ``(path, name)`` pairs: a folder gives its supported
    files that are not hidden, its subfolders' included (hidden folders left out, links to folders not
    followed), each named by its path below the folder; a pattern (``**`` reaches every depth) and a
    file give the files themselves, each named by its file name.

    Raises
    ------
    InputError
        A path or pattern that names nothing, or no supported file at all.
    """
    found = []
    for item in inputs:
        item = str(item)
        if os.path.isdir(item):
            found += sorted(((path, os.path.relpath(path, item)) for path in _folder_files(item)),
                            key=lambda pair: pair[1])
        elif os.path.isfile(item):
            found.append((item, os.path.basename(item)))
        elif glob.has_magic(item):
            matches = [p for p in sorted(glob.glob(item, recursive=True)) if os.path.isfile(p) and _supported(p)]
            if not matches:
                raise InputError(f"{item}: the pattern matches no file")
            found += [(p, os.path.basename(p)) for p in matches]
        else:
            raise InputError(f"{item}: no such file or folder")
    unique = {}
    for path, name in found:
        unique.setdefault(os.path.abspath(path), name)
    if not unique:
        raise InputError("no input file of a supported kind")
    return list(unique.items())


def _folder_files(folder):
    """The supported files of ``folder`` and of its subfolders that are not hidden."""
    for parent, folders, names in os.walk(folder):
        folders[:] = [name for name in folders if not name.startswith(".")]
        yield from (os.path.join(parent, name) for name in names
                    if os.path.isfile(os.path.join(parent, name)) and _supported(name))


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
    """Where each input's result goes: ``out_dir`` / its name (`find_inputs`; with the suffix ``to``
    if given); with ``keep_tree``, ``out_dir`` / its path below the folder all inputs share.

    Parameters
    ----------
    inputs : list of (str, str)
        Each input's path and name, from `find_inputs`.

    Raises
    ------
    InputError
        Two inputs that would write the same output.
    """
    root = os.path.commonpath([os.path.dirname(p) for p, _ in inputs]) if keep_tree else None
    outputs, seen = [], {}
    for path, name in inputs:
        if keep_tree:
            name = os.path.relpath(path, root)
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
