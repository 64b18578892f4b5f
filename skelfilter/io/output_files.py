"""Output files: checked before anything is computed, written atomically, and never a file the run
did not make.

Every output is written to a hidden temporary file in its folder and moved onto its name in one
step, with the files it consists of (an OBJ's material library and texture, named after it), so an
output that exists is complete. What the operating system refuses (a full or read-only file
system, an immutable file, a name too long) becomes one `OutputError` that says it, with nothing
left behind.
"""

import errno
import os
import re
import stat
import tempfile

from skelfilter.errors import InputError, OutputError
from skelfilter.runtime.memory import read_field
from skelfilter.runtime.signals import deferred


def same_file(a, b):
    """Whether paths ``a`` and ``b`` name one file: the same path, or the same device and inode (a
    symbolic or hard link, a bind mount, a symlinked folder)."""
    a, b = str(a), str(b)
    if os.path.abspath(a) == os.path.abspath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except (OSError, ValueError):
        return False


def write_failure(exc, path):
    """The `OutputError` for an ``OSError`` met writing ``path``: what the system said, in its words."""
    reason = (exc.strerror or str(exc) or type(exc).__name__).lower()
    if exc.errno == errno.EPERM:
        reason += " (an immutable or append-only file or folder?)"
    return OutputError(f"{reason} writing {path}")


def check_output(path, protect=(), kinds=None):
    """Refuse an output path before anything is computed.

    ``protect`` maps what ``path`` must not be to its name in the message (``{input_path: "input"}``;
    a list means inputs), compared as files (`same_file`); ``kinds`` lists the allowed extensions
    (default: any).

    Raises
    ------
    InputError
        A wrong extension, a missing folder, a folder as the path, or one of the protected files.
    OutputError
        The folder cannot take a new file (read-only, full, immutable, no permission), the name is
        longer than its file system allows, or the file there cannot be replaced (immutable).
    """
    path = str(path)
    if not path:
        raise InputError("an output path is empty")
    names = protect if isinstance(protect, dict) else {p: "input" for p in protect}
    for other, name in names.items():
        if same_file(other, path):
            raise InputError(f"{path}: refusing to overwrite the {name} file")
    if kinds is not None:
        ext = os.path.splitext(path)[1].lower().lstrip(".")
        if ext not in kinds:
            raise InputError(f"{path}: unsupported format {ext!r} (use {', '.join(kinds)})")
    if os.path.isdir(path):
        raise InputError(f"{path}: is a folder")
    special = _special_file(path)
    if special:
        raise InputError(f"{path}: is {special}; outputs are written to a new file moved onto the name, "
                         "which would replace it (write to a regular file)")
    directory = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(directory):
        raise InputError(f"{path}: output folder does not exist")
    _check_writable(path, directory)


_SPECIAL_FILES = ((stat.S_ISFIFO, "a named pipe"), (stat.S_ISCHR, "a character device"),
                  (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def _special_file(path):
    """What kind of special file ``path`` is (following links), or None: a regular file, or none."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    return next((name for test, name in _SPECIAL_FILES if test(mode)), None)


def _check_writable(path, directory):
    """What `atomic_write` needs, tried without leaving anything: a new file in the folder, a name
    the file system takes, an existing file that can be replaced."""
    try:
        limit = os.pathconf(directory, "PC_NAME_MAX")
    except (OSError, ValueError):
        limit = None
    if limit and len(os.fsencode(os.path.basename(path))) > limit:
        raise write_failure(OSError(errno.ENAMETOOLONG, os.strerror(errno.ENAMETOOLONG)), path)
    with deferred():  # no interrupt between making the probe and removing it
        try:
            fd, probe = tempfile.mkstemp(dir=directory, prefix=".skelfilter-")
            os.close(fd)
            os.unlink(probe)
        except OSError as exc:
            raise write_failure(exc, path) from None
    if os.path.isfile(path):
        try:  # an immutable file opens for writing to no one, root included; nothing is written
            os.close(os.open(path, os.O_WRONLY | os.O_NONBLOCK))
        except OSError as exc:
            if exc.errno == errno.EPERM:
                raise write_failure(exc, path) from None


def _new_file_mode(path):
    """The mode ``open`` would give ``path``: the old file's if it exists, else 0o666 less the umask
    (a temporary file is made 0o600)."""
    if os.path.exists(path):
        return os.stat(path).st_mode & 0o7777
    return 0o666 & ~_umask()


def _umask():
    """The process' umask, read without changing it where Linux shows it (os.umask sets it to read
    it, for every thread at once)."""
    value = read_field("/proc/self/status", "Umask")
    if value is not None:
        return int(value, 8)
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def file_suffix(path):
    """The file name's suffix, two of them for a compressed file (``.nii.gz``): writers that choose
    the format by the name see the output's."""
    stem, last = os.path.splitext(path)
    return os.path.splitext(stem)[1] + last if last.lower() == ".gz" else last


def atomic_write(path, write, protect=(), sidecars=None):
    """Call ``write(tmp_path)`` then move the result onto ``path`` in one step.

    ``protect``: as in `check_output`. ``sidecars`` maps the paths of files the output consists of
    (beside it) to their bytes; they are written the same way and moved into place just before
    the output, and each must be new or already belong to the output it replaces (`check_sidecars`).

    Raises
    ------
    OutputError
        The system refused a write (the message says why); nothing is left behind.
    """
    path = str(path)
    check_output(path, protect)
    sidecars = dict(sidecars or {})
    check_sidecars(path, sidecars)
    directory = os.path.dirname(os.path.abspath(path))
    temporary = {}
    try:
        for target in [*sidecars, path]:
            with deferred():
                fd, temporary[target] = tempfile.mkstemp(dir=directory, prefix=".skelfilter-",
                                                         suffix=file_suffix(target))
            os.close(fd)
        for target, data in sidecars.items():
            with open(temporary[target], "wb") as f:
                f.write(data)
        write(temporary[path])
        with deferred():  # the files of one output appear together
            for target, tmp in temporary.items():
                os.chmod(tmp, _new_file_mode(target))
            for target, tmp in temporary.items():
                os.replace(tmp, target)
    except OSError as exc:
        raise write_failure(exc, path) from None
    finally:
        with deferred():
            for tmp in temporary.values():
                if os.path.lexists(tmp):
                    os.unlink(tmp)


def write_bytes(path, data, protect=(), sidecars=None):
    """`atomic_write` of ``data`` (bytes) to ``path``, with its ``sidecars``."""
    def write(tmp):
        with open(tmp, "wb") as f:
            f.write(data)

    atomic_write(path, write, protect, sidecars=sidecars)


def check_sidecars(path, sidecars):
    """Refuse to replace a file beside the output that is not part of it: a sidecar may replace
    only a file the output it replaces names (an OBJ's ``mtllib``, its library's ``map_Kd``).

    Raises
    ------
    OutputError
    """
    owned = _named_by(path)
    for target in sidecars:
        if os.path.lexists(target) and os.path.basename(target) not in owned:
            raise OutputError(f"{target}: exists and is not part of {path}; refusing to overwrite it "
                              "(move it, or choose another output name)")


def _named_by(path, depth=2):
    """Names of the files an existing OBJ output (or its material library) or PLY output refers to."""
    if depth == 0 or not os.path.isfile(path):
        return set()
    try:
        with open(path, "rb") as f:
            text = f.read(1 << 20).decode("utf-8", "replace")
    except OSError:
        return set()
    names = set()
    for line in text.splitlines():
        texture = re.match(r"comment\s+texturefile\s+(.+?)\s*$", line, re.I)  # a PLY's texture
        if texture:
            names.add(os.path.basename(texture.group(1)))
        words = line.split(maxsplit=1)
        if len(words) == 2 and words[0] in ("mtllib", "map_Kd", "map_Ka", "map_Ks", "map_d", "map_bump"):
            name = os.path.basename(words[1].strip())
            names.add(name)
            if words[0] == "mtllib":
                names |= _named_by(os.path.join(os.path.dirname(os.path.abspath(path)), name), depth - 1)
    return names
