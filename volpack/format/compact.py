"""The compact form of the ``.vpk`` container (format version 2, ``formats/vpk-2.md``).

Version 1 spends ~700 bytes on structure around a single chunk: a 20-byte preamble, the
JSON header, a 32-byte record, a 40-byte index entry, the summary JSON and a 32-byte
footer. A small lossy file (a few hundred bytes of payload) loses to SZ3 and SPERR on that
alone. Version 2 keeps the same parts and guarantees (one pass, no seek; random access
through footer and index; every size checked before allocation; CRCs) but

* codes the header and the summary JSON as zstd frames against a fixed dictionary shipped
  in the package (:data:`DICTIONARY`, trained on real headers; never changed once shipped:
  a new dictionary needs a new format version), when that is shorter than the text;
* writes lengths and keys as varints (unsigned LEB128), one CRC32 per record, no offsets
  and no CRCs in the index (records tile the file, so offsets follow from the sizes), a
  per-chunk error in 1, 5 or 9 bytes, and a 12-byte footer.

This module holds the byte-level pieces; :mod:`volpack.format.container` reads and writes
both versions with them.
"""

from __future__ import annotations

import functools
import hashlib
import math
import struct
from importlib import resources

from ..errors import FormatError, LimitError
from .deflate import decompressor

VERSION = 2
RECORD_TAG = 0x43  # "C": a chunk record follows
INDEX_TAG = 0x49  # "I": the index follows
END_MAGIC = b"VPK2"
FLAG_HEADER_DICT = 1  # preamble flag: the header is a dictionary-coded zstd frame
FLAGS = FLAG_HEADER_DICT
TEXT_JSON, TEXT_DICT = 0, 1  # the summary's form byte
MAX_VARINT = 10  # bytes of a varint up to 2**64 - 1

# The dictionary of format version 2. Its bytes are part of the format: the hash pins
# them, and a different dictionary means a new format version.
DICTIONARY = "vpk-dict-1.zdict"
DICTIONARY_SHA256 = "8c1ae0ec98037dd4b869293f4538a9f02620cfd43d4dce533fa1ce01b9574240"
LEVEL = 19

# footer: index length, CRC32 of the index bytes then these 4 length bytes, end magic
_FOOTER = struct.Struct("<II4s")
FOOTER_SIZE = _FOOTER.size  # 12
_F32 = struct.Struct("<f")
_F64 = struct.Struct("<d")
ERROR_ZERO, ERROR_F32, ERROR_F64 = 0, 1, 2  # per-entry error form
_ERROR_CODECS = {ERROR_F32: _F32, ERROR_F64: _F64}


# -- varints ---------------------------------------------------------------------------


def put_varint(n: int) -> bytes:
    """Unsigned LEB128: 7 bits a byte, low first, the top bit set on all but the last."""
    out = bytearray()
    while n >= 0x80:
        out.append((n & 0x7F) | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)


def get_varint(buf, pos: int, what: str) -> tuple[int, int]:
    """The varint at ``buf[pos]`` and the position after it. Refuses a varint that runs
    past the end, is longer than 10 bytes, exceeds 2**64 - 1 or is not in its shortest
    form (so every value has one encoding and the CRCs see every change)."""
    if pos < len(buf) and buf[pos] < 0x80:  # the common one-byte case, fast
        return buf[pos], pos + 1
    n = shift = 0
    for i in range(MAX_VARINT):
        if pos + i >= len(buf):
            raise FormatError(f"expected a varint ({what}) at offset {pos}, found the end")
        b = buf[pos + i]
        n |= (b & 0x7F) << shift
        shift += 7
        if not b & 0x80:
            if b == 0 and i > 0:
                raise FormatError(f"expected a shortest-form varint ({what}), found a padded one")
            if n >> 64:
                raise FormatError(f"expected a varint below 2**64 ({what}), found {n}")
            return n, pos + i + 1
    raise FormatError(f"expected a varint of at most {MAX_VARINT} bytes ({what}), found more")


def record_head(t: int, node: int, nbytes: int) -> bytes:
    """A record's bytes before its payload: tag, t, node, nbytes."""
    return bytes([RECORD_TAG]) + put_varint(t) + put_varint(node) + put_varint(nbytes)


# -- header and summary text -----------------------------------------------------------


@functools.cache
def _dictionary():
    import zstandard

    data = resources.files("volpack").joinpath("data", DICTIONARY).read_bytes()
    found = hashlib.sha256(data).hexdigest()
    if found != DICTIONARY_SHA256:  # a changed dictionary would misread every file
        raise FormatError(
            f"expected the vpk-2 dictionary {DICTIONARY} with SHA-256 {DICTIONARY_SHA256}, "
            f"found {found} (a damaged installation)"
        )
    return zstandard.ZstdCompressionDict(data)


def dict_frame(text: bytes) -> bytes:
    """``text`` as one magicless zstd frame against :data:`DICTIONARY`, declaring its size."""
    import zstandard

    params = zstandard.ZstdCompressionParameters.from_level(
        LEVEL,
        format=zstandard.FORMAT_ZSTD1_MAGICLESS,
        write_content_size=1,
        write_checksum=0,
        write_dict_id=0,
    )
    return zstandard.ZstdCompressor(dict_data=_dictionary(), compression_params=params).compress(
        text
    )


def pack_text(text: bytes) -> tuple[int, bytes]:
    """``(TEXT_DICT, frame)`` when the dictionary-coded frame is shorter than ``text``,
    else ``(TEXT_JSON, text)``."""
    frame = dict_frame(text)
    return (TEXT_DICT, frame) if len(frame) < len(text) else (TEXT_JSON, text)


def _text_decompressor():
    import zstandard

    # a crafted frame may ask for a large window: the decoder's memory stays bounded
    fmt = zstandard.FORMAT_ZSTD1_MAGICLESS
    return zstandard.ZstdDecompressor(dict_data=_dictionary(), format=fmt, max_window_size=1 << 25)


def unpack_text(form: int, data: bytes, limit: int, what: str) -> bytes:
    """The JSON bytes of a header or summary stored in ``form``; a frame must declare its
    size, within ``limit``, and hold exactly one frame."""
    if form == TEXT_JSON:
        return data
    if form != TEXT_DICT:
        raise FormatError(f"expected the {what} form {TEXT_JSON} or {TEXT_DICT}, found {form}")
    import zstandard

    fmt = zstandard.FORMAT_ZSTD1_MAGICLESS
    try:
        size = zstandard.get_frame_parameters(data, format=fmt).content_size
    except zstandard.ZstdError as e:
        raise FormatError(f"corrupt {what} frame: {e}") from None
    if size == zstandard.CONTENTSIZE_UNKNOWN:
        raise FormatError(f"corrupt {what} frame: expected it to declare its size, found none")
    if size > limit:
        raise LimitError(f"expected a {what} of at most {limit} bytes, found {size} declared")
    dobj = decompressor("vpk-2 text", _text_decompressor).decompressobj()
    try:
        out = dobj.decompress(data)
    except zstandard.ZstdError as e:
        raise FormatError(f"corrupt {what} frame: {e}") from None
    if not dobj.eof or dobj.unused_data or len(out) != size:
        raise FormatError(f"corrupt {what} frame: expected one frame of {size} bytes")
    return out


# -- index entries ---------------------------------------------------------------------


def pack_error(error: float) -> bytes:
    """A per-chunk error in the shortest of its exact forms: 0.0 in one byte, a float32
    value in five, anything else in nine."""
    if error == 0.0 and math.copysign(1.0, error) > 0:
        return bytes([ERROR_ZERO])
    try:
        if _F32.unpack(_F32.pack(error))[0] == error:
            return bytes([ERROR_F32]) + _F32.pack(error)
    except OverflowError:
        pass
    return bytes([ERROR_F64]) + _F64.pack(error)


def get_error(buf, pos: int) -> tuple[float, int]:
    if pos >= len(buf):
        raise FormatError("expected a chunk error form in the index, found the end")
    form = buf[pos]
    if form == ERROR_ZERO:
        return 0.0, pos + 1
    codec = _ERROR_CODECS.get(form)
    if codec is None:
        raise FormatError(f"expected a chunk error form 0, 1 or 2 in the index, found {form}")
    if pos + 1 + codec.size > len(buf):
        raise FormatError("expected a chunk error in the index, found the end")
    return codec.unpack_from(buf, pos + 1)[0], pos + 1 + codec.size


def pack_entry(t: int, node: int, nbytes: int, error: float) -> bytes:
    return put_varint(t) + put_varint(node) + put_varint(nbytes) + pack_error(error)


MIN_ENTRY = 4  # three one-byte varints and the one-byte error form


def pack_footer(index: bytes, crc) -> bytes:
    """The footer after ``index``; ``crc(data, start)`` is zlib's CRC32."""
    length = struct.pack("<I", len(index))
    return _FOOTER.pack(len(index), crc(length, crc(index)), END_MAGIC)


def unpack_footer(foot: bytes) -> tuple[int, int]:
    """``(index length, CRC32)`` of a footer whose end magic is checked."""
    length, icrc, end = _FOOTER.unpack(foot)
    if end != END_MAGIC:
        raise FormatError(
            f"expected the end magic {END_MAGIC!r} in the last 4 bytes, found {end!r} "
            "(truncated or not a complete vpk file)"
        )
    return length, icrc
