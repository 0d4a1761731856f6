"""Streams around the ``.vpk`` container: standard input that can be peeked at, spooling a
pipe to a seekable file, a source's size, and sniffing a file's or a pipe's stream kind
(the header's ``kind``) without consuming it."""

from __future__ import annotations

import io
import os
import sys
from typing import BinaryIO

from ..errors import FormatError
from .container import MAGIC, Reader, is_seekable, is_vpk


class _Rewindable(io.RawIOBase):
    """A pipe whose first bytes can be read twice: what is read while ``recording`` is
    kept, and :meth:`rewind` serves it again before the rest of the pipe."""

    def __init__(self, f: BinaryIO) -> None:
        self._f = f
        self._kept = bytearray()
        self._replay = b""
        self.recording = False

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return False

    def readinto(self, b) -> int:
        if self._replay:
            n = min(len(b), len(self._replay))
            b[:n] = self._replay[:n]
            self._replay = self._replay[n:]
        else:
            n = self._f.readinto(b) or 0
        if self.recording:
            self._kept += bytes(b[:n])
        return n

    def rewind(self) -> None:
        self._replay = bytes(self._kept) + self._replay
        self._kept = bytearray()
        self.recording = False


_STDIN: BinaryIO | None = None


def stdin() -> BinaryIO:
    """Standard input as a binary stream whose container header :func:`vpk_kind` can
    peek at without losing it (a pipe is wrapped; a redirected file is used as it is).
    Whatever reads standard input should read it through this."""
    global _STDIN
    raw = sys.stdin.buffer
    if _STDIN is None or getattr(_STDIN, "_f", _STDIN) is not raw:  # new stdin (tests)
        _STDIN = raw if is_seekable(raw) else _Rewindable(raw)
    return _STDIN


def spool(f: BinaryIO, memory: int = 64 << 20) -> BinaryIO:
    """The rest of stream ``f`` in a seekable temporary file (in memory up to ``memory``
    bytes, on disk past that), positioned at its start: what reading a pipe's index
    (written last) needs."""
    import shutil
    import tempfile

    out = tempfile.SpooledTemporaryFile(max_size=memory)  # noqa: SIM115 - the caller closes it
    shutil.copyfileobj(f, out, 1 << 20)
    out.seek(0)
    return out


def source_size(source) -> int:
    """Bytes of a path, or of a seekable binary file from its start."""
    if isinstance(source, (str, os.PathLike)):
        return os.path.getsize(source)
    pos = source.tell()
    end = source.seek(0, io.SEEK_END)
    source.seek(pos)
    return end


def _peek_stdin_kind() -> str | None:
    f = stdin()
    if isinstance(f, _Rewindable):
        f.recording = True
        try:
            return _kind_of(f)
        finally:
            f.rewind()
    start = f.tell()
    try:
        return _kind_of(f)
    finally:
        f.seek(start)


def _kind_of(f) -> str | None:
    try:
        with Reader(f) as r:
            return r.header.get("kind")
    except FormatError:
        return None


def vpk_kind(path) -> str | None:
    """The header's ``kind`` when ``path`` is a readable ``.vpk`` file (or ``"-"``, a
    ``.vpk`` stream on standard input, peeked at without consuming it), else None."""
    if path == "-":
        return _peek_stdin_kind()
    if not os.path.isfile(path):
        return None
    with open(path, "rb") as f:
        if not is_vpk(f.read(len(MAGIC))):
            return None
    with Reader(path) as r:
        return r.header.get("kind")
