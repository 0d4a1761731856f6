"""Sections: the length-prefixed framing the codecs use for the parts of one chunk payload
(a u32 little-endian length, then the bytes; ``formats/vpk-1.md`` leaves payloads to the
codecs, whose specs name this framing)."""

from __future__ import annotations

import struct

from ..errors import FormatError

_SECTION = struct.Struct("<I")


def put_section(body: bytes) -> bytes:
    """``body`` preceded by its length (u32, little-endian): the framing the codecs use
    for the parts of one chunk payload."""
    return _SECTION.pack(len(body)) + body


def take_section(data: memoryview, pos: int, what: str) -> tuple[bytes, int]:
    """The section :func:`put_section` wrote at ``pos`` and the position after it;
    ``what`` names the payload in the error a truncated or overlong section raises."""
    if pos + 4 > len(data):
        raise FormatError(f"{what}: a section length runs past the end")
    (n,) = _SECTION.unpack(data[pos : pos + 4])
    pos += 4
    if n > len(data) - pos:
        raise FormatError(f"{what}: expected a section of {n} bytes, found {len(data) - pos}")
    return bytes(data[pos : pos + n]), pos + n
