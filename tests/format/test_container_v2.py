"""The .vpk container, format version 2 (formats/vpk-2.md): golden file, round trips through
every kind of source, random access, the dictionary, damage and limits."""

from __future__ import annotations

import hashlib
import io
import struct
import zlib
from pathlib import Path

import pytest
from conftest import Pipe, damaged
from hypothesis import given, settings
from hypothesis import strategies as st

from volpack.errors import ChecksumError, FormatError, LimitError
from volpack.format import compact
from volpack.format.container import MAGIC, Reader, Writer
from volpack.format.streams import spool

EXAMPLES = Path(__file__).resolve().parents[2] / "formats" / "examples"
GOLDEN = EXAMPLES / "tiny-v2.vpk"

# The content of formats/examples/tiny-v2.vpk, written out here on purpose (not imported
# from scripts/make_examples.py) so that a change to the script cannot move the target.
GOLDEN_HEADER = {"kind": "test", "note": "golden vpk-2 container", "shape": [2, 3]}
GOLDEN_CHUNKS = [
    (0, 0, b"alpha", 0.0),
    (0, 1, b"", 0.25),
    (1, 7, bytes(range(16)), 1.5),
    (2, 300, bytes(range(200)), 0.1),
]
GOLDEN_SUMMARY = {"chunks": 4, "payload_nbytes": 221, "max_error": 1.5}

CHUNKS = [(0, 0, b"first chunk"), (0, 3, b"\x00" * 40), (2, 1, b""), (2, 2**40, b"xyz" * 7)]


def build(chunks=CHUNKS, header=None, summary=None, errors=None) -> bytes:
    buf = io.BytesIO()
    with Writer(buf, {"kind": "test"} if header is None else header) as w:
        for i, (t, node, payload) in enumerate(chunks):
            w.write(t, node, payload, error=i / 2 if errors is None else errors[i])
        w.close(summary if summary is not None else {"n": len(chunks)})
    return buf.getvalue()


def decode_all(source, **kw):
    with Reader(source, **kw) as r:
        chunks = list(r)
        return r.header, chunks, [e[:4] + (e.error,) for e in r.entries], r.summary


def sources(data: bytes):
    return [data, io.BytesIO(data), io.BufferedReader(Pipe(data)), Pipe(data, step=1)]


# -- golden file, spec, dictionary -----------------------------------------------------


def test_golden_file_decodes_through_both_paths():
    data = GOLDEN.read_bytes()
    assert data[8:10] == b"\x02\x00"  # version 2
    for src in sources(data):
        with Reader(src) as r:
            assert r.version == 2
            assert r.header == GOLDEN_HEADER
            got = list(r)
            assert r.summary == GOLDEN_SUMMARY
            assert [(e.t, e.node, e.nbytes, e.error) for e in r.entries] == [
                (t, n, len(p), e) for t, n, p, e in GOLDEN_CHUNKS
            ]
        assert got == [(t, n, p) for t, n, p, _ in GOLDEN_CHUNKS]


def test_golden_file_is_reproduced_byte_for_byte():
    buf = io.BytesIO()
    with Writer(buf, dict(reversed(list(GOLDEN_HEADER.items())))) as w:
        for t, n, p, e in GOLDEN_CHUNKS:
            w.write(t, n, p, e)
        w.close(GOLDEN_SUMMARY)
    assert buf.getvalue() == GOLDEN.read_bytes()


def test_dictionary_is_the_pinned_one():
    from importlib import resources

    data = resources.files("volpack").joinpath("data", compact.DICTIONARY).read_bytes()
    assert hashlib.sha256(data).hexdigest() == compact.DICTIONARY_SHA256
    assert compact._dictionary().dict_id() != 0  # a trained dictionary, with its tables


def test_version_1_files_still_decode_and_version_1_is_still_written():
    old = (EXAMPLES / "tiny-v1.vpk").read_bytes()
    with Reader(old) as r:
        assert r.version == 1 and len(list(r)) == 3
    assert build()[8:10] == b"\x02\x00"
    buf = io.BytesIO()
    with Writer(buf, {"kind": "test"}, version=1) as w:
        w.write(0, 0, b"x")
    assert Reader(buf.getvalue()).version == 1
    with pytest.raises(Exception, match="version"):
        Writer(io.BytesIO(), {}, version=3)


def test_a_small_single_chunk_file_is_mostly_payload():
    header = {
        "brick": [64, 33, 36], "dtype": "<f4", "kind": "volume", "meta": {},
        "codec": {"coder": "arith", "fill": None, "id": "bounded", "integer": False,
                  "lo": -9999.0, "max_error": 103.1, "max_levels": None, "order": "dfs",
                  "qdtype": "uint8", "step": 206.2, "value_range": 10306.78662109375,
                  "wavelet": "53"},
        "origin": [0.0, 0.0, 0.0], "shape": [64, 33, 36], "spacing": [1.0, 1.0, 1.0],
        "volpack": "0.1.0",
    }  # fmt: skip
    summary = {"error_bound": 103.1, "lossless": False, "max_error": 76.91569519042969,
               "mode": "bounded", "payload_nbytes": 142, "psnr": 48.4168, "ratio": 2141.75,
               "raw_nbytes": 304128, "rmse": 39.1095}  # fmt: skip
    sizes = {}
    for version in (1, 2):
        buf = io.BytesIO()
        with Writer(buf, header, version=version) as w:
            w.write(0, 0, bytes(142), 76.91569519042969)
            w.close(summary)
        sizes[version] = len(buf.getvalue()) - 142
        assert decode_all(buf.getvalue())[3] == summary
    assert sizes[1] > 600 and sizes[2] < 180, sizes


# -- round trips -----------------------------------------------------------------------


@pytest.mark.parametrize("summary", [{}, {"n": 4}, {"text": "x" * 3000, "v": [1.5] * 40}])
def test_round_trip_every_source(summary, tmp_path):
    data = build(summary=summary)
    path = tmp_path / "a.vpk"
    path.write_bytes(data)
    want = decode_all(data)
    assert want[1] == CHUNKS and want[3] == summary
    for src in [*sources(data), str(path)]:
        assert decode_all(src) == want
    with spool(io.BufferedReader(Pipe(data))) as f:
        assert decode_all(f) == want


def test_every_error_form_round_trips():
    errors = [0.0, -0.0, 0.25, 0.1, float("inf"), 3.4e38 * 10, -1.5]
    chunks = [(t, n + 1000 * i, p) for i, (t, n, p) in enumerate(CHUNKS * 2)]
    data = build(chunks, errors=errors + [7.0], summary={})
    with Reader(data) as r:
        got = [e.error for e in r.entries]
    assert got == errors + [7.0]
    assert str(got[1]) == "-0.0"
    nan = build([(0, 0, b"")], errors=[float("nan")])
    assert Reader(nan).entries[0].error != Reader(nan).entries[0].error


@settings(max_examples=60, deadline=None)
@given(
    st.dictionaries(
        st.tuples(st.integers(0, 2**32 - 1), st.integers(0, 2**64 - 1)),
        st.binary(max_size=300),
        max_size=6,
    ),
    st.dictionaries(st.text(max_size=8), st.integers() | st.text(max_size=20), max_size=4),
)
def test_round_trip_property(chunks, header):
    items = [(t, n, p) for (t, n), p in chunks.items()]
    data = build(items, header=header, summary={"k": len(items)})
    for src in (data, io.BufferedReader(Pipe(data, step=5))):
        h, got, _, s = decode_all(src)
        assert h == header and got == items and s == {"k": len(items)}


def test_random_access_reads_only_the_chunk():
    data = build([(0, i, bytes([i]) * 10_000) for i in range(20)])
    with Reader(io.BytesIO(data)) as r:
        before = r.bytes_read
        assert before < 600  # preamble, header, footer and index: no chunk
        assert r.read(0, 13) == bytes([13]) * 10_000
        # record head (tag, t, node, nbytes: 1 + 1 + 1 + 2 bytes), payload, CRC32
        assert r.bytes_read - before == 5 + 10_000 + 4


# -- damage, truncation, limits --------------------------------------------------------


def _expect_format_error(data: bytes) -> None:
    for src in (data, io.BufferedReader(Pipe(data, step=64))):
        with pytest.raises(FormatError):
            decode_all(src)


def test_every_bit_flip_truncation_and_trailing_byte_is_detected():
    for bad in damaged(GOLDEN.read_bytes()):
        _expect_format_error(bad)


def test_wrong_version_and_flags():
    data = bytearray(build())
    for version, flags, match in ((3, data[10], "version 1 or 2, found 3"), (2, 6, "flags")):
        bad = bytearray(data)
        struct.pack_into("<HB", bad, 8, version, flags)
        with pytest.raises(FormatError, match=match):
            Reader(bytes(bad))


def _with_header(text: bytes, form_flag: int = 0, hlen: int | None = None) -> bytes:
    """A version 2 preamble and header (CRC valid) before the records of ``build()``."""
    pre = MAGIC + struct.pack("<HB", 2, form_flag)
    pre += compact.put_varint(len(text) if hlen is None else hlen) + text
    return pre + struct.pack("<I", zlib.crc32(pre))


def test_header_forms_and_bad_frames():
    # a header stored as JSON text (flag 0) and as a frame (flag 1) decode alike
    text = b'{"kind":"test","shape":[1,2,3]}'
    for src in (_with_header(text), _with_header(compact.dict_frame(text), 1)):
        assert decode_all(src + _rest())[:2] == ({"kind": "test", "shape": [1, 2, 3]}, CHUNKS)
    # a frame declaring more than the header limit is refused before it is decoded
    big = compact.dict_frame(b'{"k":"' + b"a" * 5000 + b'"}')
    assert len(big) < 200
    with pytest.raises(LimitError):
        Reader(_with_header(big, 1) + _rest(), max_header=1000)
    with pytest.raises(FormatError, match="corrupt header frame"):
        Reader(_with_header(b"\x00\x01\x02junk", 1) + _rest())
    with pytest.raises(FormatError, match="one frame"):
        Reader(_with_header(big + b"\x00", 1) + _rest())


def _rest() -> bytes:
    """The records, index and footer of ``build()`` (whose header is 15 bytes of JSON)."""
    data = build()
    start = Reader(data).entries[0].offset
    return data[start:]


def test_non_canonical_varints_are_refused():
    assert compact.get_varint(compact.put_varint(300), 0, "x") == (300, 2)
    with pytest.raises(FormatError, match="shortest"):
        compact.get_varint(b"\x81\x00", 0, "x")
    with pytest.raises(FormatError, match="10 bytes"):
        compact.get_varint(b"\xff" * 11, 0, "x")
    with pytest.raises(FormatError, match="2\\*\\*64"):
        compact.get_varint(b"\xff" * 9 + b"\x7f", 0, "x")
    with pytest.raises(FormatError, match="end"):
        compact.get_varint(b"\x80", 0, "x")


def _rewrite_index(data: bytes, index: bytes) -> bytes:
    ilen = struct.unpack_from("<I", data, len(data) - 12)[0]
    start = len(data) - 12 - ilen
    return data[:start] + index + compact.pack_footer(index, zlib.crc32)


def test_huge_declared_sizes_never_allocate():
    # header length near 2**64 in the preamble
    huge = MAGIC + struct.pack("<HB", 2, 0) + b"\xff" * 9 + b"\x01"
    with pytest.raises(LimitError):
        Reader(huge + bytes(40))
    # a stream record declaring 2**60 payload bytes
    data = build()
    off = Reader(data).entries[0].offset
    head = bytes([compact.RECORD_TAG, 0, 0]) + compact.put_varint(2**60)
    bad = data[:off] + head + data[off + 4 :]
    with pytest.raises(LimitError):
        decode_all(io.BufferedReader(Pipe(bad)))
    # an index declaring 2**60 entries (its CRC valid)
    ilen = struct.unpack_from("<I", data, len(data) - 12)[0]
    index = data[len(data) - 12 - ilen : len(data) - 12]
    n_raw = compact.put_varint(len(CHUNKS))
    bad_index = index[:1] + compact.put_varint(2**60) + index[1 + len(n_raw) :]
    with pytest.raises(FormatError, match="entries"):
        Reader(_rewrite_index(data, bad_index))
    # an index length beyond the file
    foot = struct.pack("<I", 2**32 - 1)
    bad = data[:-12] + foot + struct.pack("<I", zlib.crc32(foot)) + compact.END_MAGIC
    with pytest.raises(FormatError, match="index"):
        Reader(bad)


def test_index_that_disagrees_with_a_record_is_refused():
    data = build()
    with Reader(data) as r:
        e = r.entries[1]
    # the record's node changed (and its CRC recomputed): the index no longer matches
    head = compact.record_head(e.t, e.node + 1, e.nbytes)
    payload = data[e.offset + len(head) : e.offset + len(head) + e.nbytes]
    rec = head + payload + struct.pack("<I", zlib.crc32(payload, zlib.crc32(head)))
    bad = data[: e.offset] + rec + data[e.offset + len(rec) :]
    with pytest.raises(FormatError, match="as the index says"):
        decode_all(bad)
    with pytest.raises(FormatError, match="match the record"):
        decode_all(io.BufferedReader(Pipe(bad)))


def test_unknown_summary_and_error_forms():
    data = build([(0, 0, b"x")], summary={})
    ilen = struct.unpack_from("<I", data, len(data) - 12)[0]
    index = bytearray(data[len(data) - 12 - ilen : len(data) - 12])
    # tag, count 1, entry (t 0, node 0, nbytes 1, error form 0), summary form, length, {}
    assert bytes(index) == b"\x49\x01\x00\x00\x01\x00\x00\x02{}"
    for pos, match in ((5, "error form"), (6, "summary form")):
        bad = bytearray(index)
        bad[pos] = 9
        for src in (_rewrite_index(data, bytes(bad)),):
            with pytest.raises(FormatError, match=match):
                decode_all(src)


def test_limits_are_configurable_and_verify_false_skips_the_record_crc():
    data = build([(0, 0, b"x" * 1000)])
    with pytest.raises(LimitError):
        Reader(data, max_chunk=999)
    with pytest.raises(LimitError):
        list(Reader(io.BufferedReader(Pipe(data)), max_chunk=999))
    assert list(Reader(data, max_chunk=1000)) == [(0, 0, b"x" * 1000)]
    bad = bytearray(data)
    bad[Reader(data).entries[0].offset + 10] ^= 1
    with pytest.raises(ChecksumError):
        list(Reader(bytes(bad)))
    assert list(Reader(bytes(bad), verify=False))[0][2][4:6] == b"xy"


def test_describe_names_the_version_and_lists_the_same_entries():
    from volpack.format.describe import describe

    new = describe(str(EXAMPLES / "vpk2-wavelet-53-arith-u8.vpk"))
    old = describe(str(EXAMPLES / "wavelet-53-arith-dfs-u8.vpk"))
    assert (new["vpk_version"], old["vpk_version"]) == (2, 1)
    assert new["header"] == old["header"] and new["chunks"] == old["chunks"] == 8
    strip = [{k: v for k, v in e.items() if k != "offset"} for e in new["entries"]]
    assert strip == [{k: v for k, v in e.items() if k != "offset"} for e in old["entries"]]
    assert new["file_nbytes"] < old["file_nbytes"] - 700


def test_reused_decompressors_recover_after_damage_and_serve_threads():
    """The header text and side frames are decoded by one decompressor per thread, kept:
    a damaged frame leaves it fit for the next, a frame asking for a huge window is still
    refused, and threads decoding at once each get their own text back."""
    import threading

    from volpack.format.deflate import deflate, inflate

    texts = [b'{"kind":"volume","n":%d,"pad":"%s"}' % (i, b"xy" * i) for i in range(40)]
    frames = [compact.dict_frame(t) for t in texts]
    for i, (t, f) in enumerate(zip(texts, frames)):
        bad = bytearray(f)
        bad[len(bad) // 2] ^= 0x5A
        try:
            compact.unpack_text(compact.TEXT_DICT, bytes(bad), 1 << 16, "header")
        except FormatError:
            pass
        assert compact.unpack_text(compact.TEXT_DICT, f, 1 << 16, "header") == t
        side = deflate(t)
        with pytest.raises(FormatError):
            inflate(side[: len(side) // 2], 1 << 16, "side")
        assert inflate(side, 1 << 16, "side") == t
    # a frame that declares a window past the bound (2^25) is refused on a reused one too
    import zstandard

    params = zstandard.ZstdCompressionParameters.from_level(
        3, window_log=27, format=zstandard.FORMAT_ZSTD1_MAGICLESS, write_content_size=1
    )
    wide = zstandard.ZstdCompressor(compression_params=params).compress(b"a" * (1 << 26))
    with pytest.raises((FormatError, LimitError)):
        compact.unpack_text(compact.TEXT_DICT, wide, 1 << 27, "header")
    got: dict = {}

    def work(k: int) -> None:
        got[k] = all(
            compact.unpack_text(compact.TEXT_DICT, frames[(k + j) % 40], 1 << 16, "h")
            == texts[(k + j) % 40]
            and inflate(deflate(texts[j % 40]), 1 << 16, "s") == texts[j % 40]
            for j in range(300)
        )

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert got == dict.fromkeys(range(4), True)
