"""Errors a user can act on: the CLI prints them as one line and exits non-zero."""


class SkelfilterError(Exception):
    """Base class of the errors skelfilter reports to its users."""


class InputError(SkelfilterError):
    """The input mesh or volume cannot be used (unreadable, empty, NaN coordinates)."""


class OpenSurfaceError(InputError):
    """A new closed mesh was asked of a surface that encloses no solid (an open scan)."""


class ParameterError(SkelfilterError, ValueError):
    """A parameter is out of range or of the wrong kind."""


class ResourceError(SkelfilterError):
    """The requested grid would not fit in the memory available."""


class OutputError(SkelfilterError):
    """An output cannot be written: the system refused it (a full or read-only file system, an
    immutable file, a name too long) or it would replace a file the run did not make."""
