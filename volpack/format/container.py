"""The ``.vpk`` container: a JSON header, checksummed chunks keyed ``(t, node)``, an index.

Layout of format version 1 (little-endian; byte-level specification ``formats/vpk-1.md``)::

    preamble   20 bytes   magic, version u16, flags u16, header length u32, header CRC32
    header     JSON object (UTF-8)
    records    per chunk: 32-byte record header + payload; self-delimiting
    index      magic, count, one 40-byte entry per chunk, summary JSON
    footer     32 bytes   index offset, index length, index CRC32, footer CRC32, end magic

Version 2 (``formats/vpk-2.md``, :mod:`volpack.format.compact`, written by default) has
the same parts in a compact form: dictionary-coded header and summary, varint sizes, one
CRC32 per record, a 12-byte footer; readers take both.

Chunks come first and the index last, so a writer needs one pass and never seeks (a pipe
works) and a reader of a seekable file finds any chunk through the footer and index
without reading the others. Every size read from a file is checked against a limit and
against the bytes that remain before anything is allocated; damaged or truncated input
raises :class:`~volpack.errors.FormatError` (or its subclasses
:class:`~volpack.errors.ChecksumError` and :class:`~volpack.errors.LimitError`).
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import struct
import sys
import zlib
from collections.abc import Iterator
from typing import BinaryIO, NamedTuple

from ..errors import ChecksumError, FormatError, LimitError, OptionError, reading
from . import compact

__all__ = [
    "MAGIC",
    "VERSION",
    "Entry",
    "Reader",
    "Writer",
    "is_vpk",
]

MAGIC = b"VPK\x00\r\n\x1a\n"
"""First 8 bytes of every ``.vpk`` file (the CR LF / ^Z bytes catch text-mode mangling)."""
# Format version written by default (formats/vpk-2.md), and version 1's record tags
# (formats/vpk-1.md, section 3).
VERSION = compact.VERSION
VERSIONS = (1, 2)
RECORD_MAGIC = b"CHNK"
INDEX_MAGIC = b"VIDX"
END_MAGIC = b"VPKEND\x00\x00"

DEFAULT_MAX_HEADER = 1 << 24
DEFAULT_MAX_CHUNK = 1 << 32

# preamble: magic, version, flags, header length, header crc32
_PREAMBLE = struct.Struct("<8sHHII")
# record header: magic, t, node, payload nbytes, payload crc32, crc32 of the first 28 bytes
_RECORD = struct.Struct("<4sIQQII")
_RECORD_BODY = struct.Struct("<4sIQQI")
# index head: magic, count; entry: t, node, offset, nbytes, crc32, error; summary length
_INDEX_HEAD = struct.Struct("<4sQ")
_ENTRY = struct.Struct("<IQQQId")
_SUMMARY_LEN = struct.Struct("<I")
# footer: index offset, index nbytes, index crc32, crc32 of the first 20 bytes, end magic
_FOOTER = struct.Struct("<QQII8s")
_FOOTER_BODY = struct.Struct("<QQI")

PREAMBLE_SIZE = _PREAMBLE.size  # 20
RECORD_SIZE = _RECORD.size  # 32
ENTRY_SIZE = _ENTRY.size  # 40
FOOTER_SIZE = _FOOTER.size  # 32

_MAX_T = (1 << 32) - 1
_MAX_NODE = (1 << 64) - 1
_READ_STEP = 1 << 20  # streams are read in steps so a false size never allocates much


class Entry(NamedTuple):
    """One chunk as listed in the index.

    ``offset`` is the position of the chunk's record from the start of the container;
    ``nbytes`` is the payload's length. ``crc32`` is the payload's CRC32 in version 1; in
    version 2 the index holds none (it is None; each record's CRC32 covers the record).
    """

    t: int
    node: int
    offset: int
    nbytes: int
    crc32: int | None
    error: float


def _check_before_index(e: Entry, end: int, ioff: int) -> None:
    """An index entry's record must end before the index itself begins."""
    if end > ioff:
        raise FormatError(
            f"expected chunk (t={e.t}, node={e.node}) to end before the index at {ioff}, "
            f"found its end at {end}"
        )


def is_vpk(prefix: bytes) -> bool:
    """True when ``prefix`` (the first bytes of a file, at least 8) starts with :data:`MAGIC`."""
    return bytes(prefix[: len(MAGIC)]) == MAGIC


def _crc(data) -> int:
    return zlib.crc32(data) & 0xFFFFFFFF


def _dump_json(obj: dict, what: str) -> bytes:
    if not isinstance(obj, dict):
        raise TypeError(f"expected the {what} to be a dict, found {type(obj).__name__}")
    try:
        text = json.dumps(
            obj, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False
        )
    except (TypeError, ValueError) as e:
        raise OptionError(f"expected a JSON-serialisable {what}: {e}") from None
    return text.encode("utf-8")


def _reject_constant(name: str):
    raise ValueError(f"non-standard JSON constant {name}")


def _load_json(data: bytes, what: str) -> dict:
    try:
        obj = json.loads(bytes(data).decode("utf-8"), parse_constant=_reject_constant)
    except UnicodeDecodeError as e:
        raise FormatError(
            f"expected UTF-8 text in the {what}, found invalid bytes ({e.reason})"
        ) from None
    except (ValueError, RecursionError) as e:
        raise FormatError(f"expected valid JSON in the {what}, found an error: {e}") from None
    if not isinstance(obj, dict):
        raise FormatError(f"expected the {what} to be a JSON object, found {type(obj).__name__}")
    return obj


# -- writing ---------------------------------------------------------------------------


class Writer:
    """Write a ``.vpk`` container in one pass.

    Parameters
    ----------
    target : str, PathLike or binary file
        A path is written atomically (temporary file beside it, renamed on
        :meth:`close`); ``'-'`` is standard output. An open binary file (``BytesIO``,
        ``sys.stdout.buffer``) is written from its current position, never seeked.
    header : dict
        The JSON header (stored with sorted keys, so equal dicts give equal bytes).
    force : bool
        Replace an existing file at ``target`` (otherwise
        :class:`~volpack.format.atomic.OutputExistsError`).
    max_header : int
        Refuse a header whose JSON is longer than this many bytes.
    version : int
        Container format version: 2 (compact, ``formats/vpk-2.md``) or 1
        (``formats/vpk-1.md``, for readers older than version 2).

    Use it as a context manager: leaving the block normally closes the container (with an
    empty summary unless :meth:`close` was called); leaving it through an exception
    discards a path target, so no partial file remains.
    """

    def __init__(
        self,
        target: str | os.PathLike | BinaryIO,
        header: dict,
        *,
        force: bool = False,
        max_header: int = DEFAULT_MAX_HEADER,
        version: int = VERSION,
    ) -> None:
        if version not in VERSIONS:
            raise OptionError(f"expected a vpk format version in {VERSIONS}, found {version!r}")
        self.version = version
        head = _dump_json(header, "header")
        if len(head) > min(max_header, _MAX_T):
            raise LimitError(
                f"expected a header of at most {max_header} bytes, found {len(head)} bytes"
            )
        self._stack = contextlib.ExitStack()
        self._closed = False
        self._entries: list[Entry] = []
        self._keys: set[tuple[int, int]] = set()
        self._name = None  # the output's path, for write errors
        if isinstance(target, (str, os.PathLike)):
            from .atomic import atomic_open

            self._file = self._stack.enter_context(atomic_open(target, force=force))
            self._name = os.fspath(target)
        else:
            self._file = target
        self._pos = 0
        if version == 1:
            pre = _PREAMBLE.pack(MAGIC, 1, 0, len(head), _crc(head)) + head
        else:  # magic, version, flags, varint length, header, CRC32 of all these bytes
            form, head = compact.pack_text(head)
            flags = compact.FLAG_HEADER_DICT if form == compact.TEXT_DICT else 0
            pre = MAGIC + struct.pack("<HB", 2, flags) + compact.put_varint(len(head)) + head
            pre += struct.pack("<I", _crc(pre))
        try:
            self._put(pre)
        except BaseException:
            self._abort(*sys.exc_info())
            raise

    @property
    def entries(self) -> list[Entry]:
        """The chunks written so far, in file order."""
        return list(self._entries)

    @property
    def nbytes(self) -> int:
        """Bytes written so far: the whole file's size once closed."""
        return self._pos

    def _put(self, data: bytes) -> None:
        try:
            self._file.write(data)
        except OSError as e:
            from .atomic import write_error

            named = write_error(e, self._name)
            if named is not e:
                raise named from None
            raise
        self._pos += len(data)

    def write(self, t: int, node: int, payload: bytes, error: float = 0.0) -> Entry:
        """Append the chunk ``(t, node)``; return its index entry.

        ``error`` is a per-chunk figure (e.g. the maximum reconstruction error) kept in
        the index. A key already written raises ``ValueError``.
        """
        if self._closed:
            raise OptionError("cannot write to a closed vpk Writer")
        t, node = int(t), int(node)
        if not 0 <= t <= _MAX_T:
            raise OptionError(f"expected t in 0..{_MAX_T}, found {t}")
        if not 0 <= node <= _MAX_NODE:
            raise OptionError(f"expected node in 0..{_MAX_NODE}, found {node}")
        if (t, node) in self._keys:
            raise OptionError(f"chunk (t={t}, node={node}) was already written")
        data = memoryview(payload).cast("B")
        if self.version == 1:
            pcrc = _crc(data)
            body = _RECORD_BODY.pack(RECORD_MAGIC, t, node, data.nbytes, pcrc)
            entry = Entry(t, node, self._pos, data.nbytes, pcrc, float(error))
            self._put(body + struct.pack("<I", _crc(body)))
            self._put(data)
        else:  # head, payload, CRC32 of both
            head = compact.record_head(t, node, data.nbytes)
            entry = Entry(t, node, self._pos, data.nbytes, None, float(error))
            self._put(head)
            self._put(data)
            self._put(struct.pack("<I", zlib.crc32(data, zlib.crc32(head)) & 0xFFFFFFFF))
        self._keys.add((t, node))
        self._entries.append(entry)
        return entry

    def close(self, summary: dict | None = None) -> None:
        """Write the index (with ``summary``, a JSON dict of what is known only after
        encoding) and the footer, then commit the file. A second call does nothing."""
        if self._closed:
            return
        try:
            summ = _dump_json({} if summary is None else summary, "summary")
            if len(summ) > _MAX_T:
                raise LimitError(f"expected a summary of at most {_MAX_T} bytes, found {len(summ)}")
            if self.version == 2:
                self._close_v2(summ)
            else:
                self._close_v1(summ)
            with contextlib.suppress(AttributeError, OSError, ValueError):
                self._file.flush()
        except BaseException:
            self._abort(*sys.exc_info())
            raise
        self._closed = True
        self._stack.close()

    def _close_v2(self, summ: bytes) -> None:
        form, summ = compact.pack_text(summ)
        parts = [bytes([compact.INDEX_TAG]), compact.put_varint(len(self._entries))]
        parts.extend(compact.pack_entry(e.t, e.node, e.nbytes, e.error) for e in self._entries)
        parts += [bytes([form]), compact.put_varint(len(summ)), summ]
        index = b"".join(parts)
        if len(index) > _MAX_T:
            raise LimitError(f"expected an index of at most {_MAX_T} bytes, found {len(index)}")
        self._put(index)
        self._put(compact.pack_footer(index, zlib.crc32))

    def _close_v1(self, summ: bytes) -> None:
        index_offset = self._pos
        parts = [_INDEX_HEAD.pack(INDEX_MAGIC, len(self._entries))]
        parts.extend(_ENTRY.pack(*e) for e in self._entries)
        parts.append(_SUMMARY_LEN.pack(len(summ)))
        parts.append(summ)
        index = b"".join(parts)
        self._put(index)
        body = _FOOTER_BODY.pack(index_offset, len(index), _crc(index))
        self._put(_FOOTER.pack(index_offset, len(index), _crc(index), _crc(body), END_MAGIC))

    def _abort(self, exc_type, exc, tb) -> None:
        self._closed = True
        self._stack.__exit__(exc_type, exc, tb)

    def __enter__(self) -> Writer:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is None:
            self.close()
        elif not self._closed:
            # discard: the atomic target removes its temporary file and re-raises
            with contextlib.suppress(BaseException):
                self._abort(exc_type, exc, tb)


# -- reading ---------------------------------------------------------------------------


class Reader:
    """Read a ``.vpk`` container.

    Parameters
    ----------
    source : str, PathLike, bytes-like or binary file
        A path, the container's bytes, or an open binary file positioned at the start of
        the container (seekable or not; a pipe is read in one pass).
    max_header : int
        Largest header or summary JSON accepted, in bytes.
    max_chunk : int
        Largest chunk payload accepted, in bytes.
    verify : bool
        Check each payload's CRC32 when it is read (structure is always checked).

    Attributes
    ----------
    header : dict
        The JSON header.
    entries : list of Entry
        The chunks in file order. For a seekable source they come from the index at the
        end (no chunk is read); for a stream they grow as :meth:`__iter__` advances
        (with ``error`` NaN until the index at the end replaces them).
    summary : dict or None
        The summary stored with the index. For a non-seekable stream it is ``None``
        until every chunk has been iterated (the index follows the chunks).
    seekable : bool
        Whether :meth:`read` (random access) is available.
    bytes_read : int
        Bytes read from the source so far.
    """

    def __init__(
        self,
        source: str | os.PathLike | bytes | bytearray | memoryview | BinaryIO,
        *,
        max_header: int = DEFAULT_MAX_HEADER,
        max_chunk: int = DEFAULT_MAX_CHUNK,
        verify: bool = True,
    ) -> None:
        self.max_header = int(max_header)
        self.max_chunk = int(max_chunk)
        self.verify = bool(verify)
        self.bytes_read = 0
        self.summary: dict | None = None
        self.entries: list[Entry] = []
        self._by_key: dict[tuple[int, int], Entry] = {}
        self._owned: BinaryIO | None = None
        self._consumed = False
        self.path: str | None = None  # named in its FormatErrors (FormatError.path)
        if isinstance(source, (str, os.PathLike)):
            self._f: BinaryIO = open(source, "rb")  # noqa: SIM115 - closed by close()
            self._owned = self._f
            self.path = os.fspath(source)
        elif isinstance(source, (bytes, bytearray, memoryview)):
            self._f = io.BytesIO(source if isinstance(source, bytes) else bytes(source))
        elif hasattr(source, "read"):
            self._f = source
        else:
            raise TypeError(
                f"expected a path, bytes or a binary file, found {type(source).__name__}"
            )
        try:
            self.seekable = is_seekable(self._f)
            if self.seekable:
                self._start = self._f.tell()
                self._length = self._f.seek(0, io.SEEK_END) - self._start
                self._f.seek(self._start)
            else:
                self._start, self._length = 0, None
            self._pos = 0  # position relative to the start (streams)
            with reading(self.path):
                self.header = self._read_preamble()
                self._data_start = self._pos
                if self.seekable:
                    self._read_index_seekable()
        except BaseException:
            self.close()
            raise

    # -- low level

    def _need(self, n: int, what: str) -> None:
        if self._length is not None and self._pos + n > self._length:
            raise FormatError(
                f"expected {n} bytes of {what} at offset {self._pos}, found "
                f"{max(self._length - self._pos, 0)} (truncated)"
            )

    def _take(self, n: int, what: str) -> bytes:
        """Read exactly ``n`` bytes at the current position, in steps (no big allocation
        on a false size: the caller has checked ``n`` against a limit already)."""
        self._need(n, what)
        if n <= _READ_STEP:
            data = self._f.read(n) if n else b""
            got = len(data) if data is not None else 0
            if got < n:
                data = (data or b"") + self._fill(n - got)
        else:
            parts, left = [], n
            while left:
                piece = self._f.read(min(left, _READ_STEP)) or b""
                if not piece:
                    break
                parts.append(piece)
                left -= len(piece)
            data = b"".join(parts)
        self.bytes_read += len(data)
        if len(data) != n:
            self._pos += len(data)
            raise FormatError(
                f"expected {n} bytes of {what}, found {len(data)} before the end (truncated)"
            )
        self._pos += n
        return data

    def _fill(self, n: int) -> bytes:
        parts = []
        while n:
            piece = self._f.read(n)
            if not piece:
                break
            parts.append(piece)
            n -= len(piece)
        return b"".join(parts)

    def _seek(self, pos: int) -> None:
        self._f.seek(self._start + pos)
        self._pos = pos

    # -- structure

    def _read_preamble(self) -> dict:
        pre = self._take(10, "preamble")
        magic, version = struct.unpack("<8sH", pre)
        if magic != MAGIC:
            raise FormatError(f"expected the vpk magic {MAGIC!r}, found {magic!r}")
        if version not in VERSIONS:
            raise FormatError(f"expected vpk format version 1 or 2, found {version}")
        self.version = version
        if version == 2:
            return self._read_preamble_v2(pre)
        pre += self._take(PREAMBLE_SIZE - 10, "preamble")
        _, _, flags, hlen, hcrc = _PREAMBLE.unpack(pre)
        if flags != 0:
            raise FormatError(f"expected preamble flags 0, found {flags}")
        if hlen > self.max_header:
            raise LimitError(
                f"expected a header of at most {self.max_header} bytes, found {hlen} declared"
            )
        head = self._take(hlen, "header")
        if _crc(head) != hcrc:
            raise ChecksumError(f"expected header CRC32 {hcrc:08x}, found {_crc(head):08x}")
        return _load_json(head, "header")

    def _take_varint(self, what: str) -> bytes:
        """The bytes of the varint at the current position (read one at a time)."""
        raw = b""
        while len(raw) < compact.MAX_VARINT:
            raw += self._take(1, what)
            if not raw[-1] & 0x80:
                break
        return raw

    def _read_preamble_v2(self, pre: bytes) -> dict:
        pre += self._take(1, "preamble flags")
        flags = pre[-1]
        if flags & ~compact.FLAGS:
            raise FormatError(f"expected preamble flags within {compact.FLAGS}, found {flags}")
        raw = self._take_varint("header length")
        pre += raw
        hlen = compact.get_varint(raw, 0, "header length")[0]
        if hlen > self.max_header:
            raise LimitError(
                f"expected a header of at most {self.max_header} bytes, found {hlen} declared"
            )
        head = self._take(hlen, "header")
        (hcrc,) = struct.unpack("<I", self._take(4, "header CRC32"))
        if zlib.crc32(head, zlib.crc32(pre)) != hcrc:
            raise ChecksumError(
                f"expected header CRC32 {hcrc:08x}, found {zlib.crc32(head, zlib.crc32(pre)):08x}"
            )
        form = compact.TEXT_DICT if flags & compact.FLAG_HEADER_DICT else compact.TEXT_JSON
        return _load_json(compact.unpack_text(form, head, self.max_header, "header"), "header")

    def _read_index_seekable(self) -> None:
        length = self._length
        assert length is not None
        if self.version == 2:
            return self._read_index_seekable_v2(length)
        foot = self._take_footer(length, FOOTER_SIZE)
        ioff, ilen, icrc, fcrc, end = _FOOTER.unpack(foot)
        if end != END_MAGIC:
            raise FormatError(
                f"expected the end magic {END_MAGIC!r} in the last 8 bytes, found {end!r} "
                "(truncated or not a complete vpk file)"
            )
        if _crc(foot[: _FOOTER_BODY.size]) != fcrc:
            raise ChecksumError(
                f"expected footer CRC32 {fcrc:08x}, found {_crc(foot[: _FOOTER_BODY.size]):08x}"
            )
        if ioff < self._data_start or ioff + ilen != length - FOOTER_SIZE:
            raise FormatError(
                f"expected the index to lie between offset {self._data_start} and the footer at "
                f"{length - FOOTER_SIZE}, found offset {ioff} and length {ilen}"
            )
        self._seek(ioff)
        index = self._take(ilen, "index")
        if _crc(index) != icrc:
            raise ChecksumError(f"expected index CRC32 {icrc:08x}, found {_crc(index):08x}")
        self._parse_index(index, ioff)

    def _take_footer(self, length: int, size: int) -> bytes:
        """The last ``size`` bytes of a seekable container of ``length`` bytes."""
        if length < self._data_start + size:
            raise FormatError(
                f"expected at least {self._data_start + size} bytes (header and footer), "
                f"found {length} (truncated)"
            )
        self._seek(length - size)
        return self._take(size, "footer")

    def _read_index_seekable_v2(self, length: int) -> None:
        size = compact.FOOTER_SIZE
        foot = self._take_footer(length, size)
        ilen, icrc = compact.unpack_footer(foot)
        ioff = length - size - ilen
        if ioff < self._data_start:
            raise FormatError(
                f"expected an index of at most {length - size - self._data_start} bytes "
                f"before the footer, found {ilen} declared"
            )
        self._seek(ioff)
        index = self._take(ilen, "index")
        found = zlib.crc32(foot[:4], zlib.crc32(index))
        if found != icrc:
            raise ChecksumError(f"expected index CRC32 {icrc:08x}, found {found:08x}")
        self._parse_index_v2(index, ioff)

    def _parse_index_v2(self, index: bytes, ioff: int) -> list[Entry]:
        """Decode and check a version 2 index whose bytes passed their CRC."""
        n = len(index)
        if n < 4 or index[0] != compact.INDEX_TAG:
            raise FormatError(f"expected the index tag {compact.INDEX_TAG:#x} at offset {ioff}")
        count, pos = compact.get_varint(index, 1, "index count")
        if count > (n - pos) // compact.MIN_ENTRY:
            raise FormatError(
                f"expected at most {(n - pos) // compact.MIN_ENTRY} entries in an index of "
                f"{n} bytes, found {count} declared"
            )
        entries = []
        expect = self._data_start
        for _ in range(count):
            start = pos
            t, pos = compact.get_varint(index, pos, "entry t")
            node, pos = compact.get_varint(index, pos, "entry node")
            nbytes, pos = compact.get_varint(index, pos, "entry nbytes")
            head = 1 + pos - start  # the record head: its tag and these same three varints
            error, pos = compact.get_error(index, pos)
            if t > _MAX_T:
                raise FormatError(f"expected t in 0..{_MAX_T}, found {t} in the index")
            self._check_chunk_size(t, node, nbytes)
            e = Entry(t, node, expect, nbytes, None, error)
            expect += head + nbytes + 4
            _check_before_index(e, expect, ioff)
            entries.append(e)
        if expect != ioff:
            raise FormatError(f"expected the index at offset {expect}, found it at {ioff}")
        if pos >= n:
            raise FormatError("expected the summary form in the index, found the end")
        form = index[pos]
        slen, pos = compact.get_varint(index, pos + 1, "summary length")
        self._check_summary_length(slen, room=n - pos)
        text = compact.unpack_text(form, index[pos:], self.max_header, "summary")
        return self._set_index(entries, _load_json(text, "summary"))

    def _set_index(self, entries: list[Entry], summary: dict) -> list[Entry]:
        by_key = {}
        for e in entries:
            if (e.t, e.node) in by_key:
                raise FormatError(
                    f"expected unique chunk keys, found (t={e.t}, node={e.node}) twice"
                )
            by_key[(e.t, e.node)] = e
        self.entries, self._by_key, self.summary = entries, by_key, summary
        return entries

    def _parse_index(self, index: bytes, ioff: int) -> list[Entry]:
        """Decode and check an index whose bytes passed their CRC; set entries/summary."""
        n = len(index)
        fixed = _INDEX_HEAD.size + _SUMMARY_LEN.size
        if n < fixed:
            raise FormatError(f"expected an index of at least {fixed} bytes, found {n}")
        magic, count = _INDEX_HEAD.unpack_from(index, 0)
        if magic != INDEX_MAGIC:
            raise FormatError(f"expected the index magic {INDEX_MAGIC!r}, found {magic!r}")
        if count > (n - fixed) // ENTRY_SIZE:
            raise FormatError(
                f"expected at most {(n - fixed) // ENTRY_SIZE} entries in an index of {n} "
                f"bytes, found {count} declared"
            )
        pos = _INDEX_HEAD.size
        entries = []
        expect = self._data_start
        for _ in range(count):
            e = Entry(*_ENTRY.unpack_from(index, pos))
            pos += ENTRY_SIZE
            if e.offset != expect:
                raise FormatError(
                    f"expected chunk (t={e.t}, node={e.node}) at offset {expect}, found {e.offset}"
                )
            self._check_chunk_size(e.t, e.node, e.nbytes)
            expect = e.offset + RECORD_SIZE + e.nbytes
            _check_before_index(e, expect, ioff)
            entries.append(e)
        if expect != ioff:
            raise FormatError(f"expected the index at offset {expect}, found it at {ioff}")
        (slen,) = _SUMMARY_LEN.unpack_from(index, pos)
        pos += _SUMMARY_LEN.size
        self._check_summary_length(slen, room=n - pos)
        return self._set_index(entries, _load_json(index[pos:], "summary"))

    def _read_record_v2(self, e: Entry) -> bytes:
        """The payload of the version 2 record of entry ``e`` at the current position."""
        head = compact.record_head(e.t, e.node, e.nbytes)
        found = self._take(len(head), "chunk record head")
        if found != head:
            raise FormatError(
                f"expected record (t={e.t}, node={e.node}, nbytes={e.nbytes}) at offset "
                f"{e.offset} as the index says, found other bytes"
            )
        return self._record_payload_v2(e, head)

    def _record_payload_v2(self, e: Entry, head: bytes) -> bytes:
        payload = self._take(e.nbytes, f"payload of chunk (t={e.t}, node={e.node})")
        (rcrc,) = struct.unpack("<I", self._take(4, "chunk record CRC32"))
        if self.verify or not self.seekable:
            found = zlib.crc32(payload, zlib.crc32(head))
            if found != rcrc:
                raise ChecksumError(
                    f"expected record CRC32 {rcrc:08x} for chunk (t={e.t}, node={e.node}), "
                    f"found {found:08x}"
                )
        return payload

    def _read_record(self, expected: Entry | None, rec: bytes | None = None) -> bytes:
        """Read the record at the current position and return its payload. ``rec`` is its
        32-byte record header when the caller has read it already (streams); ``expected``
        is the index entry it must match (seekable sources)."""
        offset = self._pos
        if rec is None:
            rec = self._take(RECORD_SIZE, "chunk record header")
        else:
            offset -= RECORD_SIZE
        magic, t, node, nbytes, pcrc, rcrc = _RECORD.unpack(rec)
        if magic != RECORD_MAGIC:
            raise FormatError(
                f"expected a chunk record {RECORD_MAGIC!r} at offset {offset}, found {magic!r}"
            )
        if _crc(rec[: _RECORD_BODY.size]) != rcrc:
            raise ChecksumError(
                f"expected chunk record header CRC32 {rcrc:08x} at offset {offset}, "
                f"found {_crc(rec[: _RECORD_BODY.size]):08x}"
            )
        if expected is not None and (t, node, nbytes, pcrc) != (
            expected.t,
            expected.node,
            expected.nbytes,
            expected.crc32,
        ):
            raise FormatError(
                f"expected record (t={expected.t}, node={expected.node}, nbytes="
                f"{expected.nbytes}) at offset {offset} as the index says, found (t={t}, "
                f"node={node}, nbytes={nbytes})"
            )
        self._check_chunk_size(t, node, nbytes)
        payload = self._take(nbytes, f"payload of chunk (t={t}, node={node})")
        if self.verify and _crc(payload) != pcrc:
            raise ChecksumError(
                f"expected payload CRC32 {pcrc:08x} for chunk (t={t}, node={node}), "
                f"found {_crc(payload):08x}"
            )
        self._last = Entry(t, node, offset, nbytes, pcrc, math.nan)
        return payload

    # -- public

    def keys(self) -> list[tuple[int, int]]:
        """The ``(t, node)`` keys known so far, in file order."""
        return [(e.t, e.node) for e in self.entries]

    def __contains__(self, key) -> bool:
        return tuple(key) in self._by_key

    def __len__(self) -> int:
        return len(self.entries)

    def read(self, t: int, node: int) -> bytes:
        """Return the payload of chunk ``(t, node)``, reading only that chunk (seekable
        sources only; iterate a stream instead)."""
        if not self.seekable:
            raise FormatError(
                "expected a seekable source for random access, found a stream; iterate it"
            )
        e = self._by_key.get((int(t), int(node)))
        if e is None:
            raise FormatError(f"expected a chunk (t={t}, node={node}), found none in the index")
        with reading(self.path):
            self._seek(e.offset)
            return self._read_entry(e)

    def _read_entry(self, e: Entry) -> bytes:
        return self._read_record_v2(e) if self.version == 2 else self._read_record(e)

    def __iter__(self) -> Iterator[tuple[int, int, bytes]]:
        """Yield ``(t, node, payload)`` in file order. A stream is read once, ending with
        its index and footer (after which :attr:`summary` is set)."""
        if self.seekable:
            for e in list(self.entries):
                with reading(self.path):
                    self._seek(e.offset)
                    payload = self._read_entry(e)
                yield e.t, e.node, payload
            return
        if self._consumed:
            raise FormatError("expected a fresh stream, found it already iterated once")
        self._consumed = True
        yield from self._iter_stream_v2() if self.version == 2 else self._iter_stream()

    def _iter_stream_v2(self) -> Iterator[tuple[int, int, bytes]]:
        seen: list[Entry] = []
        keys: set[tuple[int, int]] = set()
        while True:
            offset = self._pos
            tag = self._take(1, "chunk record or index tag")
            if tag[0] == compact.INDEX_TAG:
                break
            if tag[0] != compact.RECORD_TAG:
                raise FormatError(
                    f"expected a chunk record tag {compact.RECORD_TAG:#x} or the index tag "
                    f"{compact.INDEX_TAG:#x} at offset {offset}, found {tag[0]:#x}"
                )
            head = tag
            fields = []
            for what in ("t", "node", "nbytes"):
                raw = self._take_varint(f"chunk {what}")
                fields.append(compact.get_varint(raw, 0, f"chunk {what}")[0])
                head += raw
            t, node, nbytes = fields
            if t > _MAX_T:
                raise FormatError(f"expected t in 0..{_MAX_T}, found {t} at offset {offset}")
            self._check_chunk_size(t, node, nbytes)
            if (t, node) in keys:
                raise FormatError(f"expected unique chunk keys, found (t={t}, node={node}) twice")
            e = Entry(t, node, offset, nbytes, None, math.nan)
            payload = self._record_payload_v2(e, head)
            keys.add((t, node))
            seen.append(e)
            self.entries.append(e)
            yield t, node, payload
        ioff = self._pos - 1
        raw = self._take_varint("index count")
        count = compact.get_varint(raw, 0, "index count")[0]
        if count != len(seen):
            raise FormatError(
                f"expected {len(seen)} index entries (the chunks read), found {count}"
            )
        parts = [tag, raw]
        for _ in range(count):
            parts += [self._take_varint("index entry") for _ in range(3)]
            form = self._take(1, "index entry error form")
            parts += [form, self._take({0: 0, 1: 4, 2: 8}.get(form[0], 0), "index entry error")]
        parts.append(self._take(1, "summary form"))
        raw = self._take_varint("summary length")
        slen = compact.get_varint(raw, 0, "summary length")[0]
        self._check_summary_length(slen)
        index = b"".join(parts) + raw + self._take(slen, "summary")
        foot = self._take(compact.FOOTER_SIZE, "footer")
        ilen, icrc = compact.unpack_footer(foot)
        if ilen != len(index):
            raise FormatError(
                f"expected the footer to give the index length {len(index)}, found {ilen}"
            )
        found = zlib.crc32(foot[:4], zlib.crc32(index))
        if found != icrc:
            raise ChecksumError(f"expected index CRC32 {icrc:08x}, found {found:08x}")
        # version 2 entries carry no CRC: compare t, node, offset and size
        self._end_of_stream(seen, self._parse_index_v2(index, ioff), 4)

    def _iter_stream(self) -> Iterator[tuple[int, int, bytes]]:
        seen: list[Entry] = []
        keys: set[tuple[int, int]] = set()
        while True:
            offset = self._pos
            magic = self._take(4, "chunk record or index magic")
            if magic == INDEX_MAGIC:
                break
            if magic != RECORD_MAGIC:
                raise FormatError(
                    f"expected a chunk record {RECORD_MAGIC!r} or the index {INDEX_MAGIC!r} "
                    f"at offset {offset}, found {magic!r}"
                )
            rest = self._take(RECORD_SIZE - 4, "chunk record header")
            payload = self._read_record(None, magic + rest)
            e = self._last
            if (e.t, e.node) in keys:
                raise FormatError(
                    f"expected unique chunk keys, found (t={e.t}, node={e.node}) twice"
                )
            keys.add((e.t, e.node))
            seen.append(e)
            self.entries.append(e)
            yield e.t, e.node, payload
        ioff = self._pos - 4
        head = INDEX_MAGIC + self._take(_INDEX_HEAD.size - 4, "index count")
        (count,) = struct.unpack_from("<Q", head, 4)
        if count != len(seen):
            raise FormatError(
                f"expected {len(seen)} index entries (the chunks read), found {count}"
            )
        body = self._take(count * ENTRY_SIZE + _SUMMARY_LEN.size, "index entries")
        (slen,) = _SUMMARY_LEN.unpack_from(body, count * ENTRY_SIZE)
        self._check_summary_length(slen)
        index = head + body + self._take(slen, "summary")
        foot = self._take(FOOTER_SIZE, "footer")
        f_ioff, f_ilen, icrc, fcrc, end = _FOOTER.unpack(foot)
        if end != END_MAGIC:
            raise FormatError(f"expected the end magic {END_MAGIC!r}, found {end!r}")
        if _crc(foot[: _FOOTER_BODY.size]) != fcrc:
            raise ChecksumError(
                f"expected footer CRC32 {fcrc:08x}, found {_crc(foot[: _FOOTER_BODY.size]):08x}"
            )
        if (f_ioff, f_ilen) != (ioff, len(index)):
            raise FormatError(
                f"expected the footer to point at the index (offset {ioff}, {len(index)} bytes), "
                f"found offset {f_ioff}, {f_ilen} bytes"
            )
        if _crc(index) != icrc:
            raise ChecksumError(f"expected index CRC32 {icrc:08x}, found {_crc(index):08x}")
        self._end_of_stream(seen, self._parse_index(index, ioff), 5)

    def _check_chunk_size(self, t: int, node: int, nbytes: int) -> None:
        if nbytes > self.max_chunk:
            raise LimitError(
                f"expected chunks of at most {self.max_chunk} bytes, found {nbytes} declared "
                f"for (t={t}, node={node})"
            )

    def _check_summary_length(self, slen: int, room: int | None = None) -> None:
        """A declared summary length: within the header limit and, when the index is read
        whole, filling the ``room`` left in it."""
        if slen > self.max_header:
            raise LimitError(
                f"expected a summary of at most {self.max_header} bytes, found {slen} declared"
            )
        if room is not None and slen != room:
            raise FormatError(
                f"expected the summary to fill the rest of the index ({room} bytes), "
                f"found {slen} declared"
            )

    def _end_of_stream(self, seen: list[Entry], entries: list[Entry], width: int) -> None:
        """A stream read to its footer: its index must list the records read (their first
        ``width`` fields), and nothing may follow."""
        for a, b in zip(seen, entries):
            if a[:width] != b[:width]:
                raise FormatError(
                    f"expected the index entry {tuple(b[:width])} to match the record read, "
                    f"found {tuple(a[:width])}"
                )
        extra = self._f.read(1)
        if extra:
            raise FormatError(f"expected the end of the stream after the footer, found {extra!r}")

    def close(self) -> None:
        """Close the file if the reader opened it (a path source)."""
        if self._owned is not None:
            self._owned.close()
            self._owned = None

    def __enter__(self) -> Reader:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        kind = self.header.get("kind") if hasattr(self, "header") else None
        return f"<vpk.Reader kind={kind!r} chunks={len(self.entries)} seekable={self.seekable}>"


def is_seekable(f) -> bool:
    """Whether ``f`` can seek, asking politely (pipes, sockets and odd wrappers say no
    or raise)."""
    try:
        if not f.seekable():
            return False
        f.tell()
        return True
    except (AttributeError, OSError, ValueError):
        return False
