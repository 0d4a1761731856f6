"""The one exception family of volpack.

Every error the library raises on purpose is a :class:`VolpackError`. Bad files and
streams raise :class:`FormatError`, which is also a ``ValueError`` so that callers who
only know the standard library still catch it. Messages say what was expected and
what was found.
"""


class VolpackError(Exception):
    """Base class of every error volpack raises on purpose."""


class FormatError(VolpackError, ValueError):
    """A file, stream or argument does not have the expected form."""


class ChecksumError(FormatError):
    """Stored bytes do not match their recorded checksum."""


class LimitError(FormatError):
    """A size read from a stream exceeds the stream's length or a configured limit."""
