"""The one exception family of volpack.

Every error the library raises on purpose is a :class:`VolpackError`. Bad arguments
raise :class:`OptionError`, bad files and streams :class:`FormatError`; both are also
``ValueError`` so that callers who only know the standard library still catch them. Messages say what was expected and
what was found.
"""

import contextlib
import os

# The exit status of a command that met an exception volpack did not raise on purpose (a
# bug to report): the CLI's and, for the commands it runs, the resident server's.
EXIT_INTERNAL = 3


class VolpackError(Exception):
    """Base class of every error volpack raises on purpose."""


class OptionError(VolpackError, ValueError):
    """An argument (a parameter of a library call, a command-line option) is not valid.

    Messages name the Python parameter (``max_error``); the command line translates the
    name to its flag (``--max-error``) where it reports the error.
    """


class FormatError(VolpackError, ValueError):
    """A file or stream does not have the expected form.

    :attr:`path` is the file it came from when a reader of a named file raised it (the
    command line puts it before the message, which stays the library's); None for bytes,
    streams and errors of no file.
    """

    path: str | None = None


@contextlib.contextmanager
def reading(path):
    """Name ``path`` (a file's path, or None) in the :class:`FormatError` raised inside,
    unless an inner reader named its own file."""
    try:
        yield
    except FormatError as e:
        if path is not None and e.path is None:
            e.path = os.fspath(path)
        raise


class ChecksumError(FormatError):
    """Stored bytes do not match their recorded checksum."""


class LimitError(FormatError):
    """A size read from a stream exceeds the stream's length or a configured limit."""
