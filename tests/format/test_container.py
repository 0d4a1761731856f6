"""The .vpk container, format version 1 (formats/vpk-1.md): round trips, random access, golden
file, damage and limits. Version 2 is tests/format/test_container_v2.py."""

from __future__ import annotations

import io
import os
import struct
import threading
import tracemalloc
import zlib
from pathlib import Path

import pytest
from conftest import Pipe
from hypothesis import given
from hypothesis import strategies as st

from volpack.errors import ChecksumError, FormatError, LimitError
from volpack.format.atomic import OutputExistsError
from volpack.format.container import (
    FOOTER_SIZE,
    MAGIC,
    PREAMBLE_SIZE,
    RECORD_SIZE,
    Entry,
    Reader,
    is_vpk,
)
from volpack.format.container import Writer as _Writer
from volpack.format.streams import spool, stdin, vpk_kind

GOLDEN = Path(__file__).resolve().parents[2] / "formats" / "examples" / "tiny-v1.vpk"

# The content of formats/examples/tiny-v1.vpk, written out here on purpose (not imported from
# scripts/make_examples.py) so that a change to the script cannot silently move the target.
GOLDEN_HEADER = {"kind": "test", "note": "golden vpk-1 container", "shape": [2, 3]}
GOLDEN_CHUNKS = [(0, 0, b"alpha", 0.0), (0, 1, b"", 0.25), (1, 7, bytes(range(16)), 1.5)]
GOLDEN_SUMMARY = {"chunks": 3, "payload_nbytes": 21, "max_error": 1.5}

CHUNKS = [(0, 0, b"first chunk"), (0, 3, b"\x00" * 40), (2, 1, b""), (2, 2**40, b"xyz" * 7)]


def Writer(*args, **kw):  # noqa: N802 - the version 1 writer, under the name the tests use
    return _Writer(*args, version=1, **kw)


def crc(b: bytes) -> int:
    return zlib.crc32(b) & 0xFFFFFFFF


def build(chunks=CHUNKS, header=None, summary=None) -> bytes:
    buf = io.BytesIO()
    with Writer(buf, {"kind": "test"} if header is None else header) as w:
        for i, (t, node, payload) in enumerate(chunks):
            w.write(t, node, payload, error=i / 2)
        w.close(summary if summary is not None else {"n": len(chunks)})
    return buf.getvalue()


class Sink:
    """A write-only binary target with no seek or tell at all."""

    def __init__(self):
        self.parts: list[bytes] = []

    def write(self, b):
        self.parts.append(bytes(b))
        return len(b)


def decode_all(source, **kw):
    """Everything a reader can tell: header, chunks, entries, summary."""
    with Reader(source, **kw) as r:
        chunks = list(r)
        return r.header, chunks, list(r.entries), r.summary


# -- golden file and determinism -------------------------------------------------------


def test_golden_file_decodes():
    with Reader(str(GOLDEN)) as r:
        assert r.seekable
        assert r.header == GOLDEN_HEADER
        assert r.summary == GOLDEN_SUMMARY
        assert [(e.t, e.node, e.nbytes, e.error) for e in r.entries] == [
            (t, n, len(p), err) for t, n, p, err in GOLDEN_CHUNKS
        ]
        assert [e.crc32 for e in r.entries] == [crc(p) for _, _, p, _ in GOLDEN_CHUNKS]
        assert list(r) == [(t, n, p) for t, n, p, _ in GOLDEN_CHUNKS]
        for t, n, p, _ in GOLDEN_CHUNKS:
            assert r.read(t, n) == p
    # the stream reader agrees
    h, chunks, entries, summary = decode_all(io.BufferedReader(Pipe(GOLDEN.read_bytes())))
    assert (h, summary) == (GOLDEN_HEADER, GOLDEN_SUMMARY)
    assert chunks == [(t, n, p) for t, n, p, _ in GOLDEN_CHUNKS]
    assert [e.error for e in entries] == [err for *_, err in GOLDEN_CHUNKS]


def test_golden_file_is_reproduced_byte_for_byte():
    buf = io.BytesIO()
    with Writer(buf, dict(reversed(list(GOLDEN_HEADER.items())))) as w:  # key order is irrelevant
        for t, n, p, err in GOLDEN_CHUNKS:
            w.write(t, n, p, err)
        w.close(GOLDEN_SUMMARY)
    assert buf.getvalue() == GOLDEN.read_bytes()


# -- round trips -----------------------------------------------------------------------


def _check(source, data_chunks=CHUNKS):
    h, chunks, entries, summary = decode_all(source)
    assert h == {"kind": "test"}
    assert chunks == data_chunks
    assert summary == {"n": len(data_chunks)}
    assert [e.error for e in entries] == [i / 2 for i in range(len(data_chunks))]


def test_round_trip_path(tmp_path):
    p = tmp_path / "a.vpk"
    with Writer(p, {"kind": "test"}) as w:
        for i, (t, n, payload) in enumerate(CHUNKS):
            w.write(t, n, payload, error=i / 2)
        w.close({"n": len(CHUNKS)})
    assert p.read_bytes() == build()
    _check(p)
    _check(str(p))
    assert is_vpk(p.read_bytes()[:16])
    assert os.listdir(tmp_path) == ["a.vpk"]


@pytest.mark.parametrize("kind", ["bytes", "bytearray", "memoryview", "bytesio", "pipe"])
def test_round_trip_sources(kind):
    data = build()
    source = {
        "bytes": lambda: data,
        "bytearray": lambda: bytearray(data),
        "memoryview": lambda: memoryview(data),
        "bytesio": lambda: io.BytesIO(data),
        "pipe": lambda: io.BufferedReader(Pipe(data)),
    }[kind]()
    _check(source)


def test_round_trip_os_pipe_both_ways():
    """Writer into a real pipe (never seeks) and Reader from its other end (one pass)."""
    rfd, wfd = os.pipe()
    err = []

    def produce():
        try:
            with os.fdopen(wfd, "wb") as f, Writer(f, {"kind": "test"}) as w:
                for i, (t, n, payload) in enumerate(CHUNKS):
                    w.write(t, n, payload, error=i / 2)
                w.close({"n": len(CHUNKS)})
        except BaseException as e:  # pragma: no cover - surfaced below
            err.append(e)

    th = threading.Thread(target=produce)
    th.start()
    with os.fdopen(rfd, "rb") as f:
        r = Reader(f)
        assert not r.seekable
        assert r.summary is None  # known only after the chunks
        assert list(r) == CHUNKS
        assert r.summary == {"n": len(CHUNKS)}
        with pytest.raises(FormatError, match="already iterated"):
            list(r)
        with pytest.raises(FormatError, match="seekable"):
            r.read(0, 0)
    th.join()
    assert not err


@pytest.mark.parametrize("content", ["vpk", "npy", "empty"])
def test_stdin_kind_is_peeked_from_a_pipe_without_losing_bytes(monkeypatch, content):
    """`volpack decompress - ...` reads the header to choose a decoder, then decodes the
    whole stream: the peeked bytes of a pipe are served again."""
    buf = io.BytesIO()
    with Writer(buf, {"kind": "mesh"}) as w:
        for t, n, payload in CHUNKS:
            w.write(t, n, payload)
    blob = {"vpk": buf.getvalue(), "npy": b"\x93NUMPY" + bytes(300), "empty": b""}[content]
    rfd, wfd = os.pipe()

    def produce():
        with os.fdopen(wfd, "wb") as f:
            f.write(blob)

    th = threading.Thread(target=produce)
    th.start()
    with os.fdopen(rfd, "rb") as pipe:
        monkeypatch.setattr("sys.stdin", io.TextIOWrapper(pipe))
        assert vpk_kind("-") == ("mesh" if content == "vpk" else None)
        assert vpk_kind("-") == ("mesh" if content == "vpk" else None)  # and again
        if content == "vpk":  # `volpack info -`: a seekable copy, index included
            with spool(stdin()) as f, Reader(f) as r:
                assert r.seekable and [r.read(t, n) for t, n, _ in CHUNKS] == [
                    p for *_, p in CHUNKS
                ]
        else:
            assert stdin().read() == blob
    th.join()


def test_writer_to_sink_without_seek_or_tell():
    s = Sink()
    with Writer(s, {"kind": "test"}) as w:
        for i, (t, n, payload) in enumerate(CHUNKS):
            w.write(t, n, payload, error=i / 2)
        w.close({"n": len(CHUNKS)})
    assert b"".join(s.parts) == build()


def test_container_inside_a_larger_seekable_file():
    data = build()
    f = io.BytesIO(b"junk" + data)
    f.seek(4)
    _check(f)


@given(
    st.dictionaries(
        st.tuples(st.integers(0, 2**32 - 1), st.integers(0, 2**64 - 1)),
        st.binary(max_size=64),
        max_size=8,
    ),
    st.dictionaries(st.text(max_size=5), st.integers() | st.text(max_size=5), max_size=3),
)
@pytest.mark.slow
def test_round_trip_property(chunks, header):
    items = [(t, n, p) for (t, n), p in chunks.items()]
    data = build(items, header=header, summary={"k": len(items)})
    for src in (data, io.BufferedReader(Pipe(data, step=5))):
        h, got, entries, summary = decode_all(src)
        assert (h, got, summary) == (header, items, {"k": len(items)})
        assert all(isinstance(e, Entry) for e in entries)


# -- random access ---------------------------------------------------------------------


def test_random_access_reads_only_the_chunk():
    big = [(0, n, bytes([n]) * 10_000) for n in range(20)]
    data = build(big)
    r = Reader(io.BytesIO(data))
    before = r.bytes_read
    # opening read the preamble, header, footer and index, none of the chunks
    assert before < 2_000
    assert len(r.entries) == 20
    assert r.read(0, 13) == bytes([13]) * 10_000
    assert r.bytes_read - before == RECORD_SIZE + 10_000
    assert r.read(0, 2) == bytes([2]) * 10_000
    assert r.bytes_read - before == 2 * (RECORD_SIZE + 10_000)


def test_read_missing_key():
    r = Reader(build())
    assert (0, 3) in r and (9, 9) not in r
    with pytest.raises(FormatError, match=r"t=9, node=9"):
        r.read(9, 9)


# -- writer behaviour ------------------------------------------------------------------


def test_duplicate_key_raises():
    w = Writer(io.BytesIO(), {})
    w.write(1, 2, b"a")
    with pytest.raises(ValueError, match="already written"):
        w.write(1, 2, b"b")


def test_bad_keys_and_header_raise():
    w = Writer(io.BytesIO(), {})
    with pytest.raises(ValueError):
        w.write(-1, 0, b"")
    with pytest.raises(ValueError):
        w.write(0, 2**64, b"")
    with pytest.raises(TypeError):
        Writer(io.BytesIO(), [1, 2])  # type: ignore[arg-type]
    with pytest.raises(ValueError):
        Writer(io.BytesIO(), {"x": float("nan")})
    with pytest.raises(LimitError):
        Writer(io.BytesIO(), {"x": "y" * 100}, max_header=50)


def test_close_twice_and_implicit_close():
    buf = io.BytesIO()
    with Writer(buf, {"kind": "test"}) as w:
        w.write(0, 0, b"a")
    assert Reader(buf.getvalue()).summary == {}
    n = len(buf.getvalue())
    w.close({"late": 1})  # harmless
    assert len(buf.getvalue()) == n
    with pytest.raises(ValueError, match="closed"):
        w.write(0, 1, b"b")


def test_exception_inside_with_leaves_nothing(tmp_path):
    p = tmp_path / "x.vpk"
    with pytest.raises(RuntimeError), Writer(p, {"kind": "test"}) as w:
        w.write(0, 0, b"partial")
        raise RuntimeError("boom")
    assert os.listdir(tmp_path) == []
    with pytest.raises(ValueError), Writer(p, {}) as w:
        w.write(0, 0, b"a")
        w.write(0, 0, b"a")
    assert os.listdir(tmp_path) == []


def test_existing_target_needs_force(tmp_path):
    p = tmp_path / "x.vpk"
    p.write_bytes(b"old")
    with pytest.raises(OutputExistsError):
        Writer(p, {})
    assert p.read_bytes() == b"old"
    with Writer(p, {"kind": "test"}, force=True) as w:
        w.write(0, 0, b"new")
    with Reader(p) as r:
        assert list(r) == [(0, 0, b"new")]
    assert os.listdir(tmp_path) == ["x.vpk"]


# -- damage, truncation, limits --------------------------------------------------------


def _expect_format_error(data: bytes) -> None:
    for src in (data, io.BufferedReader(Pipe(data, step=64))):
        with pytest.raises(FormatError):
            decode_all(src)


def test_every_single_bit_flip_is_detected():
    data = GOLDEN.read_bytes()
    for i in range(len(data)):
        for bit in range(8):
            bad = bytearray(data)
            bad[i] ^= 1 << bit
            _expect_format_error(bytes(bad))


def test_every_truncation_is_detected():
    data = GOLDEN.read_bytes()
    for n in range(len(data)):
        _expect_format_error(data[:n])


def test_trailing_bytes_are_detected():
    _expect_format_error(GOLDEN.read_bytes() + b"\x00")


def test_not_a_vpk():
    assert not is_vpk(b"\x93NUMPY")
    assert not is_vpk(MAGIC[:4])
    with pytest.raises(FormatError, match="magic"):
        Reader(b"\x93NUMPY" + bytes(40))


def _patch_preamble(data: bytes, version=1, hlen=None, head=None) -> bytes:
    head = head if head is not None else data[PREAMBLE_SIZE : PREAMBLE_SIZE + hlen]
    pre = struct.pack("<8sHHII", MAGIC, version, 0, len(head) if hlen is None else hlen, crc(head))
    return pre + head


def test_wrong_version_message():
    data = build()
    _, _, _, hlen, _ = struct.unpack_from("<8sHHII", data)
    bad = _patch_preamble(data, version=3, head=data[PREAMBLE_SIZE : PREAMBLE_SIZE + hlen])
    bad += data[PREAMBLE_SIZE + hlen :]
    with pytest.raises(FormatError, match="expected vpk format version 1 or 2, found 3"):
        Reader(bad)


@pytest.mark.parametrize(
    "head, match",
    [
        (b"[1, 2]", "JSON object"),
        (b"\xff\xfe", "UTF-8"),
        (b"{nope", "valid JSON"),
        (b"[" * 100_000, "valid JSON"),
        (b'{"a": NaN}', "valid JSON"),
    ],
)
def test_bad_header_json(head, match):
    bad = _patch_preamble(b"", head=head) + bytes(64)
    with pytest.raises(FormatError, match=match):
        Reader(bad)
    with pytest.raises(FormatError, match=match):
        Reader(io.BufferedReader(Pipe(bad)))


def _fix_record(data: bytes, offset: int, nbytes: int) -> bytes:
    """Give the record at ``offset`` a new payload size, with a valid record CRC."""
    magic, t, node, _, pcrc, _ = struct.unpack_from("<4sIQQII", data, offset)
    body = struct.pack("<4sIQQI", magic, t, node, nbytes, pcrc)
    rec = body + struct.pack("<I", crc(body))
    return data[:offset] + rec + data[offset + RECORD_SIZE :]


def _peak_of_failure(fn) -> int:
    """Run ``fn``, which must raise FormatError; return the peak of memory traced."""
    tracemalloc.start()
    try:
        with pytest.raises(FormatError, match="truncated"):
            fn()
    finally:
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return peak


def test_huge_declared_sizes_never_allocate():
    data = build()
    # header length near 4 GiB: over the limit, then (with a huge limit) over the length
    huge_head = struct.pack("<8sHHII", MAGIC, 1, 0, 2**32 - 1, 0) + data[PREAMBLE_SIZE:]
    with pytest.raises(LimitError, match="at most"):
        Reader(huge_head)
    for src in (huge_head, io.BufferedReader(Pipe(huge_head))):
        assert _peak_of_failure(lambda s=src: Reader(s, max_header=2**40)) < 4 << 20

    # a record declaring an 2**60-byte payload, in a stream (no index consulted first)
    r0 = Reader(data)
    bad = _fix_record(data, r0.entries[0].offset, 2**60)
    with pytest.raises(LimitError):
        decode_all(io.BufferedReader(Pipe(bad)))
    stream = io.BufferedReader(Pipe(bad, step=4096))
    assert _peak_of_failure(lambda: decode_all(stream, max_chunk=2**62)) < 4 << 20

    # an index declaring 2**60 entries and an index length beyond the file (CRCs valid)
    ioff, ilen = struct.unpack_from("<QQ", data, len(data) - FOOTER_SIZE)
    index = bytearray(data[ioff : ioff + ilen])
    struct.pack_into("<Q", index, 4, 2**60)
    body = struct.pack("<QQI", ioff, ilen, crc(bytes(index)))
    foot = body + struct.pack("<I", crc(body)) + b"VPKEND\x00\x00"
    bad = data[:ioff] + bytes(index) + foot
    with pytest.raises(FormatError, match="entries"):
        Reader(bad)
    body = struct.pack("<QQI", ioff, 2**62, 0)
    bad = data[:-FOOTER_SIZE] + body + struct.pack("<I", crc(body)) + b"VPKEND\x00\x00"
    with pytest.raises(FormatError, match="index"):
        Reader(bad)


def test_limits_are_configurable():
    data = build([(0, 0, b"x" * 1000)])
    with pytest.raises(LimitError):
        Reader(data, max_chunk=999)
    with pytest.raises(LimitError):
        list(Reader(io.BufferedReader(Pipe(data)), max_chunk=999))
    with pytest.raises(LimitError):
        Reader(data, max_header=5)
    assert list(Reader(data, max_chunk=1000)) == [(0, 0, b"x" * 1000)]


def test_verify_false_skips_payload_crc_only():
    data = bytearray(GOLDEN.read_bytes())
    off = Reader(bytes(data)).entries[0].offset + RECORD_SIZE
    data[off] ^= 1
    with pytest.raises(ChecksumError):
        list(Reader(bytes(data)))
    got = list(Reader(bytes(data), verify=False))
    assert got[0][2] == b"`lpha"


@pytest.mark.parametrize(
    "version, spec_file, section",
    [(1, "vpk-1.md", "## 6. Worked example"), (2, "vpk-2.md", "## 7. Worked example")],
)
def test_spec_worked_example_matches_the_writer(version, spec_file, section):
    spec = (Path(__file__).parents[2] / "formats" / spec_file).read_text()
    dump = spec.split(section)[1].split("```")[1]
    # xxd lines: "00000000: " then 8 groups of 4 hex digits in columns 10..49, then ASCII
    expected = bytes.fromhex("".join(line[10:49] for line in dump.strip().splitlines()))
    buf = io.BytesIO()
    with _Writer(buf, {"kind": "test"}, version=version) as w:
        w.write(0, 1, b"hi", error=0.5)
        w.close({"n": 1})
    assert buf.getvalue() == expected
