"""What an input path must be before any reader opens it: an existing regular file."""

import os
import stat

from skelfilter.errors import InputError


def check_input_file(path, kind):
    """Refuse ``path`` unless it is a regular file (a link to one is one), naming what it is instead:
    a folder, a broken link, a pipe or a device (a reader would block on a pipe or read a device
    without end).

    Raises
    ------
    InputError
    """
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        broken = os.path.islink(path)
        raise InputError(f"{path}: no such file{' (a link to a missing file)' if broken else ''}") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(mode):
        raise InputError(f"{path}: is a folder, not a {kind} file")
    if not stat.S_ISREG(mode):
        raise InputError(f"{path}: is not a regular file (a pipe, device or socket); save the {kind} to a file "
                         "first")
