"""The exact path by the fast codec (formats/lossy-1.md step 19b, effort 'fast'): its
payload read as the spec says, every voxel bit for bit, the encoder's rule between it
and the lossless codec's exact payload, and damaged payloads refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import smooth_volume
from naive import float_signed_image

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.format.sections import take_section
from volpack.volume_codec import fastexact, lossy
from volpack.volume_codec.fast import FastCodec
from volpack.volume_codec.lossy import FLAG_EXACT, BoundedCodec
from volpack.volume_codec.palette import read_uleb, uleb


def levels_field(shape=(6, 20, 24), dtype=np.float32, seed=3):
    """A packed field per level: steps of 1/4 with an offset of its own per z slice."""
    k = np.rint(smooth_volume(shape, np.int16, seed=seed).astype(np.float64) / 8)
    z = np.arange(shape[0])[:, None, None]
    return (k * 0.25 + 0.1 * math.sqrt(2) * z - 20).astype(dtype)


def spec_floats(params, k, gap, dtype):
    """Step 19b read plainly: ``dtype(offset_z + step_z * k)`` in double precision, moved
    by ``gap`` units of the signed ordered bit image, wrapped to the float's width."""
    dtype = np.dtype(dtype)
    b = 8 * dtype.itemsize
    rows = np.broadcast_to(params, (k.shape[0], 2))
    with np.errstate(all="ignore"):
        points = np.stack(
            [rows[z, 0] + rows[z, 1] * k[z].astype(np.float64) for z in range(k.shape[0])]
        )
    s = float_signed_image(points.astype(dtype)).reshape(-1).tolist()
    out = []
    for v, g in zip(s, gap.reshape(-1).tolist()):
        v = ((v + g + (1 << (b - 1))) % (1 << b)) - (1 << (b - 1))
        out.append(v if v >= 0 else (1 << (b - 1)) - 1 - v)
    return np.array(out, dtype=f"u{dtype.itemsize}").view(dtype).reshape(k.shape)


def payload(params, k, gap) -> bytes:
    kp = FastCodec().encode(k.astype(np.int32))
    return (
        bytes([6]) + uleb(len(params)) + np.asarray(params, "<f8").tobytes() + uleb(len(kp))
        + kp + FastCodec().encode(gap.astype(np.int32))
    )  # fmt: skip


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("m", [1, 5])
@pytest.mark.parametrize("gaps", ["none", "some"])
def test_decode_follows_the_spec_bit_for_bit(dtype, m, gaps):
    r = np.random.default_rng(m + (gaps == "some"))
    shape = (5, 7, 9)
    params = np.column_stack([r.normal(0, 1e3, m), r.uniform(1e-3, 10, m)])
    params[0] = (-0.1, 0.01)  # a decimal step: products that round
    k = r.integers(-3000, 3000, shape)
    gap = np.zeros(shape, np.int64)
    if gaps == "some":
        gap.reshape(-1)[r.choice(k.size, 20, replace=False)] = r.integers(-5, 6, 20)
        gap.reshape(-1)[:2] = (2**31 - 2, -(2**31) + 2)  # far off: wraps the width in float32
    got = fastexact.decode(payload(params, k, gap), shape, dtype)
    want = spec_floats(params, k, gap, dtype)
    assert got.dtype == dtype
    np.testing.assert_array_equal(got.view(f"u{got.itemsize}"), want.view(f"u{got.itemsize}"))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_every_lattice_payload_round_trips_with_voxels_off_the_lattice(dtype):
    a = levels_field(dtype=dtype)
    if dtype == np.float32:  # a fill value off every slice's lattice: a gap of its own
        a[4, 0, :3] = a[1, 5, 5] = -999.123
    bodies = fastexact.encode(a)
    assert bodies and all(b[0] == 6 for b in bodies)
    assert a.shape[0] in {b[1] for b in bodies}  # the lattice a slice among them
    for b in bodies:
        got = fastexact.decode(b, a.shape, a.dtype)
        np.testing.assert_array_equal(got.view(f"u{a.itemsize}"), a.view(f"u{a.itemsize}"))
        if dtype == np.float32:  # the gap field is not all zero
            m = b[1]
            n, pos = read_uleb(memoryview(b), 2 + 16 * m)
            gap = FastCodec().decode(b[pos + n :], a.shape, np.int32)
            assert np.count_nonzero(gap) >= 4  # (the one-lattice fit misses more)


def test_no_payload_where_no_lattice_holds():
    a = np.random.default_rng(1).normal(0, 1, (8, 9, 10)).astype(np.float32)
    assert fastexact.encode(a) == []
    b = levels_field()
    b[0, 0, 0] = np.nan  # the lattice tool takes finite bricks only
    assert fastexact.encode(b) == []


def inner_of(body: bytes) -> memoryview:
    return take_section(memoryview(body), 1, "inner")[0]


def test_effort_fast_takes_it_and_the_other_efforts_never_do():
    a = levels_field()
    lo, hi = float(a.min()), float(a.max())
    fast = BoundedCodec.plan(a.dtype, lo, hi, 1e-3, effort="fast")
    body, err, sse, n = fast.encode_measured(a)
    assert body[0] == FLAG_EXACT and inner_of(body)[:2] == bytes([6, a.shape[0]])
    assert err == 0 == sse and n == a.size
    np.testing.assert_array_equal(fast.decode(body, a.shape, a.dtype), a)
    for effort in ("default", "max"):
        other = BoundedCodec.plan(a.dtype, lo, hi, 1e-3, effort=effort).encode(a)
        assert other[0] == FLAG_EXACT and inner_of(other)[0] == 5  # the lossless codec's


@pytest.mark.parametrize("rate", [0.0, 0.004, 1.0])
def test_the_lossless_exact_payload_is_kept_where_its_saving_pays_its_modelled_time(
    monkeypatch, rate
):
    """Rate 0: the shorter of the two; 1 byte a ns: the fast one; the default: the rule
    computed from the two lengths and the voxel count."""
    a = levels_field((8, 30, 40), seed=5)
    lo, hi = float(a.min()), float(a.max())
    monkeypatch.setattr(lossy, "FAST_BYTES_PER_NS", rate)
    body = BoundedCodec.plan(a.dtype, lo, hi, 1e-3, effort="fast").encode(a)
    lossless = BoundedCodec.plan(a.dtype, lo, hi, 1e-3).encode(a)
    fast = min((bytes([FLAG_EXACT]) + lossy.put_section(b) for b in fastexact.encode(a)), key=len)
    assert inner_of(lossless)[0] == 5 and len(lossless) < len(fast)  # on this field
    extra = (lossy.EXACT_LOSSLESS_NS - lossy.EXACT_FAST_NS) * a.size * rate
    assert body == (lossless if len(fast) - len(lossless) > extra else fast)
    assert (body == lossless) == (rate == 0.0)


def test_bricks_give_the_same_bytes_for_any_worker_count_and_decode_exactly():
    a = np.concatenate([levels_field((6, 20, 24), seed=s) for s in (1, 2, 3)], axis=2)
    one = api.compress_array(a, max_error=1e-3, effort="fast", brick=16, workers=1)
    two = api.compress_array(a, max_error=1e-3, effort="fast", brick=16, workers=2)
    assert one == two
    with Reader(one) as r:
        heads = {(p[0], inner_of(p)[0]) for _, _, p in r}
    assert (FLAG_EXACT, 6) in heads
    np.testing.assert_array_equal(api.decompress_array(one, workers=2), a)


def test_damaged_payloads_raise_format_errors_or_decode_safely():
    a = levels_field()
    (body,) = [b for b in fastexact.encode(a) if b[1] == a.shape[0]]
    for bad in [
        bytes([5]) + body[1:],  # not the mark
        body[:1],  # no lattice count
        bytes([6, 3]) + body[2:],  # neither 1 nor the z extent
        bytes([6, 0]) + body[2:],
        body[: 2 + 16 * a.shape[0] - 3],  # the rows cut
        body[: 2 + 16 * a.shape[0] + 3],  # the k field past the end
    ]:
        with pytest.raises(FormatError):
            fastexact.decode(bad, a.shape, a.dtype)
    r = np.random.default_rng(4)
    outcomes = set()
    for i in range(400):
        bad = bytearray(body)
        if i % 2:
            bad = bad[: r.integers(0, len(bad))]
        else:
            for j in r.integers(0, len(bad), 1 + i % 3):
                bad[j] ^= 1 << int(r.integers(0, 8))
        try:
            got = fastexact.decode(bytes(bad), a.shape, a.dtype)
        except FormatError:
            outcomes.add("error")
        else:
            assert got.shape == a.shape and got.dtype == a.dtype
            outcomes.add("decoded")
    assert outcomes == {"error", "decoded"}
    codec = BoundedCodec.plan(a.dtype, float(a.min()), float(a.max()), 1e-3, effort="fast")
    whole = codec.encode(a)
    for bad in (whole + b"\0", whole[:-2], bytes([FLAG_EXACT | 1]) + whole[1:]):
        with pytest.raises(FormatError):
            codec.decode(bad, a.shape, a.dtype)
    with pytest.raises(FormatError):
        codec.decode(whole, a.shape, np.int16)
