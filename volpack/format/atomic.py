"""Atomic output: write to a temporary file beside the target, then rename.

A crash, a full disk or an exception half way leaves the target as it was (absent or
the old file) and no partial file behind. An existing target is replaced only when the
caller says so, and never when it is one of the inputs.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from collections.abc import Iterator
from typing import BinaryIO

from ..errors import VolpackError


class OutputExistsError(VolpackError, FileExistsError):
    """The output exists and overwriting was not asked for."""


def check_output(path: str | os.PathLike, *, force: bool = False, inputs: tuple = ()) -> None:
    """Raise if writing ``path`` would overwrite an input, or an existing file without ``force``."""
    p = os.fspath(path)
    if p == "-":
        return
    for inp in inputs:
        ip = os.fspath(inp).split(":/")[0] if isinstance(inp, str) else os.fspath(inp)
        if ip != "-" and os.path.exists(ip) and os.path.exists(p) and os.path.samefile(ip, p):
            raise OutputExistsError(
                f"refusing to overwrite the input {ip!r}; choose another output"
            )
    if os.path.exists(p) and not force:
        raise OutputExistsError(f"output {p!r} exists; pass force=True to replace it")


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike, *, force: bool = False) -> Iterator[BinaryIO]:
    """Open ``path`` for binary writing so that it appears whole or not at all.

    ``'-'`` yields standard output's binary buffer (streams cannot be atomic; the
    caller writes in one pass).
    """
    p = os.fspath(path)
    if p == "-":
        yield sys.stdout.buffer
        sys.stdout.buffer.flush()
        return
    check_output(p, force=force)
    directory = os.path.dirname(os.path.abspath(p))
    fd, tmp = tempfile.mkstemp(prefix=".volpack-", suffix=".part", dir=directory)
    try:
        with os.fdopen(fd, "wb") as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, _default_mode())  # mkstemp makes 0600; a plain open would not
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, *, force: bool = False, suffix: str = "") -> Iterator[str]:
    """Yield a temporary path beside ``path`` for libraries that want a file name
    (h5py, nibabel, tifffile); it is renamed onto ``path`` when the block succeeds."""
    p = os.fspath(path)
    check_output(p, force=force)
    directory = os.path.dirname(os.path.abspath(p))
    fd, tmp = tempfile.mkstemp(prefix=".volpack-", suffix=suffix or ".part", dir=directory)
    os.close(fd)
    os.unlink(tmp)  # some writers refuse an existing file
    try:
        yield tmp
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _default_mode() -> int:
    """Permissions a newly created file gets from ``open``: 0666 less the umask."""
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask
