"""The Tucker codec (lossy-1.md `tucker`): its golden stream, its checks of corrupt
payloads, and the fixed order of its decoder's sums."""

from __future__ import annotations

import hashlib
import math
import struct
from pathlib import Path

import numpy as np
import pytest

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec.registry import get_codec
from volpack.volume_codec.tucker import TuckerCodec

GOLDEN = Path(__file__).resolve().parents[2] / "formats" / "examples"
STEM = "lossy-tucker-f32-lowrank"
# sha256 of the voxels lossy-tucker-f32-lowrank.vpk decodes to (float32, C order)
DECODED = "2acdad8fa1cbffe3997711b9919bb7ddcc076699e8938ba1b59184f197fd4d6e"
HEAD = struct.Struct("<dd3HI")


def lowrank_source():
    """scripts/make_examples.py's `f32-lowrank` recipe, written out again on purpose."""
    i, j, k = np.arange(40.0), np.arange(40.0), np.arange(48.0)
    f = np.zeros((40, 40, 48))
    for r, (p, q, s) in enumerate(((3, 5, 7), (11, 13, 2), (1, 4, 9), (6, 1, 5))):
        f += np.multiply.outer(
            np.multiply.outer(i * p % 17 - 8, j * q % 19 - 9), k * s % 23 - 11
        ) / (r + 1)
    f += (np.arange(f.size) * 0.6180339887 % 1.0).reshape(f.shape) * 0.05
    return f.astype(np.float32)


def test_tucker_config_and_corrupt_headers():
    """Checked before any stream is decoded (no kernel compiled)."""
    c = TuckerCodec(value_range=10.0, step=0.5)
    assert get_codec(c.get_config()) == c
    shape = (4, 5, 6)
    bad = [
        b"",
        bytes([7]),
        bytes([0]) + b"\0" * 5,  # header cut short
        bytes([0]) + HEAD.pack(0.0, 0.25, 1, 1, 1, 0) + b"\0" * 3,  # another step
        bytes([0]) + HEAD.pack(0.0, 0.5, 1, 0, 1, 0),  # ranks: some zero, not all
        bytes([0]) + HEAD.pack(0.0, 0.5, 5, 1, 1, 0) + b"\0" * 7,  # rank above the axis
        bytes([0]) + HEAD.pack(math.nan, 0.5, 0, 0, 0, 0),
        bytes([0]) + HEAD.pack(0.0, 0.5, 0, 0, 0, 0) + b"\0",  # bytes after rank 0
        bytes([0]) + HEAD.pack(0.0, 0.5, 1, 1, 1, 9) + b"\0" * 3,  # factor stream cut
        bytes([0]) + HEAD.pack(0.0, 0.5, 1, 1, 1, 0) + bytes([49, 0, 0]),  # exponent
    ]
    for payload in bad:
        with pytest.raises(FormatError):
            c.decode(payload, shape, np.float32)
    rank0 = bytes([0]) + HEAD.pack(2.5, 0.5, 0, 0, 0, 0)
    assert (c.decode(rank0, shape, np.float32) == np.float32(2.5)).all()


@pytest.mark.slow
def test_golden_tucker_stream_decodes_bit_exactly():
    blob = (GOLDEN / f"{STEM}.vpk").read_bytes()
    src = lowrank_source()
    got = api.decompress_array(blob)
    assert got.dtype == np.float32 and got.shape == src.shape
    assert hashlib.sha256(got.tobytes()).hexdigest() == DECODED
    info = api.info(blob)
    assert info["header"]["codec"]["id"] == "tucker"
    err = got.astype(np.float64) - src
    summary = info["summary"]
    assert summary["max_error"] == float(np.abs(err).max())
    rng = float(src.max()) - float(src.min())
    psnr = 20 * math.log10(rng) - 10 * math.log10(np.mean(err * err))
    assert summary["psnr"] == pytest.approx(psnr, abs=1e-4)
    assert abs(psnr - 60.0) <= 0.5


@pytest.mark.slow
def test_psnr_target_picks_tucker_only_where_shorter():
    src = lowrank_source()
    st = api.compress(src, __import__("io").BytesIO(), psnr=60.0)
    assert st["codec"]["id"] == "tucker" and abs(st["psnr"] - 60) <= 0.5
    sizes = st["search"]["bytes"]
    assert sizes["tucker"] == st["nbytes"] < sizes["error_bound"]
    noise = np.random.default_rng(1).standard_normal((40, 40, 48)).astype(np.float32)
    st = api.compress(noise, __import__("io").BytesIO(), psnr=40.0)
    assert st["codec"]["id"] == "bounded" and "bytes" not in st["search"]


@pytest.mark.slow
def test_truncated_or_altered_tucker_payloads_raise_format_error():
    blob = (GOLDEN / f"{STEM}.vpk").read_bytes()
    with Reader(blob) as r:
        ((_, _, payload),) = list(r)
        codec = get_codec(r.header["codec"])
    payload = bytes(payload)
    shape = lowrank_source().shape
    for n in range(1, len(payload), 7):
        with pytest.raises(FormatError):
            codec.decode(payload[:n], shape, np.float32)
    with pytest.raises(FormatError):
        codec.decode(payload + b"\0\0\0\0", shape, np.float32)
    rng = np.random.default_rng(0)
    for _ in range(20):  # a flipped bit past the header: an error or some voxels, no crash
        b = bytearray(payload)
        b[int(rng.integers(1 + HEAD.size, len(b)))] ^= 1 << int(rng.integers(8))
        try:
            out = codec.decode(bytes(b), shape, np.float32)
        except FormatError:
            continue
        assert out.shape == shape


@pytest.mark.slow
def test_expand_sums_in_the_stated_order():
    from volpack.volume_codec.tuckerexpand import expand

    rng = np.random.default_rng(3)
    core = rng.standard_normal((2, 3, 2))
    u = [rng.standard_normal((n, r)) for n, r in ((3, 2), (4, 3), (5, 2))]
    got = expand(core, u, 0.75, (3, 4, 5))
    t0 = _ordered_product(core, u[0], 0)
    t1 = _ordered_product(t0, u[1], 1)
    want = _ordered_product(t1, u[2], 2) + 0.75
    np.testing.assert_array_equal(got, want)


def _ordered_product(t, u, axis):
    """``t x_axis u`` in plain Python floats, each sum from 0.0 in increasing index."""
    t = np.moveaxis(t, axis, 0)
    out = np.zeros((u.shape[0], *t.shape[1:]))
    for a in range(u.shape[0]):
        for rest in np.ndindex(*t.shape[1:]):
            s = 0.0
            for j in range(u.shape[1]):
                s += float(u[a, j]) * float(t[(j, *rest)])
            out[(a, *rest)] = s
    return np.moveaxis(out, 0, axis)
