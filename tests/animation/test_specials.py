"""Animations with special voxels (NaN, +-Inf, a fill value) and lossless float frames:
bit-exact round trips, the bound on every other voxel, the labels against the previous
anchor, and corrupt special-voxel sections."""

from __future__ import annotations

import io
import struct

import numpy as np
import pytest
from click.testing import CliRunner

from volpack import synth
from volpack.animation import frame as aframe
from volpack.animation import specials
from volpack.animation import stream as animation
from volpack.cli import main
from volpack.errors import FormatError, OptionError
from volpack.format.container import Reader

# slow: the animation coder compiles its motion kernels
pytestmark = pytest.mark.slow

FILL = -9999.0


def _frames(dtype=np.float32, n=6):
    """A float field moving by a sub-voxel step, with special voxels of every kind: a
    fill border that grows, a NaN with a payload, +-Inf, -0.0, denormals, an all-NaN
    frame (3) and a constant frame (5)."""
    a = synth.translate(synth.head((12, 16, 20)), n, step=(0.5, 0.25, 0.75)).astype(dtype)
    a /= dtype(7.0)
    for t in range(n):
        a[t, :, : 2 + t, :3] = FILL
    bits = a.view(np.uint32 if dtype == np.float32 else np.uint64)
    a[1, 5, 5, 5] = np.nan
    bits[1, 5, 5, 6] = 0x7FC00123 if dtype == np.float32 else 0x7FF8000000000123  # payload
    a[2, 6, 6, 6], a[2, 6, 6, 7] = np.inf, -np.inf
    a[4, 7, 7, 7], a[4, 7, 7, 8], a[4, 7, 7, 9] = -0.0, dtype(1e-40), -dtype(1e-42)
    a[3] = np.nan
    a[5] = dtype(2.5)
    return a


def _code(frames, **kw):
    buf = io.BytesIO()
    stats = animation.compress(frames, buf, **kw)
    return buf.getvalue(), stats


def _same_bits(a, b):
    return np.array_equal(a.view(f"u{a.itemsize}"), b.view(f"u{b.itemsize}"))


def _special(a):
    return ~np.isfinite(a) | (a == FILL)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_lossless_float_round_trip_is_bit_exact(dtype):
    a = _frames(dtype)
    blob, stats = _code(a, gop_string="IPB", fill_value=FILL)
    assert stats["lossless"] and stats["max_error"] == 0.0
    out = animation.decompress(blob).data
    assert out.dtype == a.dtype and _same_bits(out, a)
    for t in range(a.shape[0]):  # frame access decodes only the anchors it needs
        assert _same_bits(animation.decompress(blob, frame=t).data, a[t])
    if dtype == np.float64:  # float64 lossless frames are coded alone
        assert set(r["type"] for r in stats["frames"]) == {"I"}


def test_bounded_float_keeps_specials_and_the_bound_on_every_other_voxel():
    a = _frames()
    e = 0.02
    blob, stats = _code(a, gop_string="IBBP", max_error=e, fill_value=FILL)
    out = animation.decompress(blob).data
    sp = _special(a)
    assert _same_bits(out[sp], a[sp])
    err = np.abs(out[~sp].astype(np.float64) - a[~sp])
    assert err.max() <= e and err.max() == stats["max_error"]
    assert not _special(out[~sp]).any()
    # the value range and the frames' errors are those of the valid voxels
    lo, hi = stats["value_range"]
    assert lo == float(a[~sp].min()) and hi == float(a[~sp].max())
    assert stats["frames"][3]["max_error"] == 0.0 and stats["frames"][3]["psnr"] is None


def test_nan_and_fill_do_not_pollute_prediction():
    """A still land mask costs next to nothing in P-frames, and the frames are
    predicted as well as without it."""
    a = synth.advect((12, 16, 20), 6, dtype=np.float32)
    land = np.zeros(a.shape[1:], bool)
    land[:, 4:9, 5:12] = True
    masked = a.copy()
    masked[:, land] = np.nan
    plain, _ = _code(a, gop_string="IPPPPP", max_error=0.01)
    blob, stats = _code(masked, gop_string="IPPPPP", max_error=0.01)
    assert [r["type"] for r in stats["frames"]] == list("IPPPPP")
    out = animation.decompress(blob).data
    assert np.isnan(out[:, land]).all() and (np.abs(out[:, ~land] - a[:, ~land]) <= 0.01).all()
    assert len(blob) < 1.2 * len(plain)
    with Reader(blob) as r:
        p_frame = r.read(1, 0)
    head = aframe._FRAME_HEAD.size
    (n,) = struct.unpack("<I", p_frame[head : head + 4])
    assert p_frame[0] & aframe.TYPE_SPECIALS and p_frame[head + 4] == specials.AGAINST_PREVIOUS
    assert n < 40  # how, palette size, one NaN, a few bytes of zero labels


@pytest.mark.parametrize("mode", [{}, {"max_error": 3}])
def test_integer_frames_with_a_fill_value(mode):
    rng = np.random.default_rng(3)
    a = (synth.translate(synth.head((10, 12, 14)), 4, step=(0.5, 0.5, 0.25)) * 40).astype(np.int16)
    a[:, :, :3] = -100
    a[2, 4, 4, 4:8] = -99  # one step from the fill: a bounded decode must not land on it
    a += rng.integers(0, 2, a.shape, dtype=np.int16)
    blob, stats = _code(a, gop_string="IPB", fill_value=-100, **mode)
    out = animation.decompress(blob).data
    sp = a == -100
    assert np.array_equal(out[sp], a[sp]) and not (out[~sp] == -100).any()
    assert np.abs(out.astype(int) - a).max() <= mode.get("max_error", 0)


def test_lossless_float_predicted_frames_beat_the_3d_floor():
    """Lossless float32 P/B frames code bit-pattern residuals; the stream is never
    longer than the frames coded one by one as 3-D volumes with the animation's frame
    codec (each frame keeps the shorter of its prediction and the frame alone). That
    codec is the lossless one at predict_version 2: an animation header stores no codec
    config, so its frames keep the tools of the files written before version 3."""
    from volpack.volume_codec.stream import compress as compress_volume

    a = np.ascontiguousarray(synth.advect((16, 16, 16), 5, dtype=np.float32))
    blob, stats = _code(a, gop_string="IPPPP")
    assert _same_bits(animation.decompress(blob).data, a)
    alone = 0
    for f in a:
        alone += compress_volume(f, io.BytesIO(), predict_version=2)["nbytes"]
    assert stats["payload_nbytes"] <= alone + 40 * a.shape[0]
    assert stats["frame_types"]["P"] >= 1


def test_refuses_what_it_cannot_code():
    a = _frames()[:3]
    with pytest.raises(OptionError, match="max_error= or losslessly"):
        _code(a, quality=63)
    with pytest.raises(OptionError, match="fill_value"):
        _code(a, fill_value=float("nan"))


# -- corrupt sections ----------------------------------------------------------------------


@pytest.fixture(scope="module")
def coded():
    a = _frames()[:3]
    blob, _ = _code(a, gop_string="IPP", max_error=0.05, fill_value=FILL)
    r = animation.open(blob)
    return r, [r._read(t) for t in range(3)]


def _special_section(payload):
    head = aframe._FRAME_HEAD.size
    (n,) = struct.unpack("<I", payload[head : head + 4])
    return head + 4, n


def _decode(r, payload, prev=None):
    return aframe.decode_frame(payload, r.shape[1:], r.dtype, prev, None, r.settings, r.brick)


def _with_body(payload, body):
    start, n = _special_section(payload)
    return payload[: start - 4] + struct.pack("<I", len(body)) + body + payload[start + n :]


@pytest.mark.parametrize(
    "why",
    ["how", "zero palette", "big palette", "palette not special", "label", "truncated", "anchor"],
)
def test_corrupt_special_sections_raise(coded, why):
    r, payloads = coded
    p = payloads[0]
    start, n = _special_section(p)
    body = bytearray(p[start : start + n])
    k = struct.unpack("<I", body[1:5])[0]
    if why == "how":
        body[0] = 7
    elif why == "zero palette":
        body[1:5] = struct.pack("<I", 0)
    elif why == "big palette":
        body[1:5] = struct.pack("<I", 10**9)
    elif why == "palette not special":
        body[5:9] = np.float32(1.5).tobytes()
    elif why == "label":  # labels naming a palette entry past the end
        sym = np.zeros(r.shape[1:], np.int64)
        sym[0, 0, 0] = k + 1
        from volpack.animation.linecode import encode_line

        body = body[: 5 + 4 * k] + encode_line(sym)
    elif why == "truncated":
        body = body[:3]
    elif why == "anchor":  # labels against an anchor, in an I-frame
        body[0] = specials.AGAINST_PREVIOUS
    with pytest.raises(FormatError):
        _decode(r, _with_body(p, bytes(body)))


def test_special_bit_in_integer_frames_without_a_fill_is_refused(coded):
    r, payloads = coded
    a = np.zeros((2, 4, 4, 4), np.uint8)
    blob, _ = _code(a, gop_string="IP")
    ri = animation.open(blob)
    p = bytearray(ri._read(0))
    p[0] |= aframe.TYPE_SPECIALS
    with pytest.raises(FormatError, match="special"):
        _decode(ri, bytes(p))


def test_cli_compresses_float_frames_with_a_fill_value(tmp_path):
    a = _frames()[:4]
    for t, f in enumerate(a):
        np.save(tmp_path / f"f{t}.npy", f)
    run = CliRunner()
    pattern, vpk, out = str(tmp_path / "f*.npy"), str(tmp_path / "a.vpk"), str(tmp_path / "o.npy")
    r = run.invoke(main, ["compress", pattern, vpk, "--gop", "IPB", "--fill-value", str(FILL)])
    assert r.exit_code == 0 and "lossless" in r.output, r.output
    assert run.invoke(main, ["decompress", vpk, out]).exit_code == 0
    assert _same_bits(np.load(out), a)
    r = run.invoke(main, ["compress", pattern, vpk, "-f", "--gop", "IPB", "--max-error", "0.05",
                          "--fill-value", str(FILL)])  # fmt: skip
    assert r.exit_code == 0, r.output
    assert run.invoke(main, ["decompress", vpk, out, "-f"]).exit_code == 0
    got, sp = np.load(out), _special(a)
    assert _same_bits(got[sp], a[sp]) and np.abs(got[~sp] - a[~sp]).max() <= 0.05
    r = run.invoke(main, ["compress", pattern, vpk, "-f", "--gop", "IPB", "--quality", "63"])
    assert r.exit_code != 0 and "--max-error" in r.output and "max_error" not in r.output
