"""(z, y, x, c) volumes: RGB or fluorescence channels last (session 32, user32). Taken as
a (t, z, y, x) series they were series of volumes 3 voxels wide (a colour-mapped MRI:
4.28:1, zstd -19 5.94:1); now they are stored as the series of their channels, header
"channels": "last", and decoded as (z, y, x, c) again. (Since session 33 an integer
volume of few distinct tuples, as rgb() here, is stored as a tuple palette by default,
test_channel_palette.py; the tests of the channels path ask tuples=False.)"""

from __future__ import annotations

import io
import os

import numpy as np
import pytest
from conftest import rewrite_header, smooth_volume

from volpack import api
from volpack.errors import FormatError, OptionError
from volpack.format.container import Reader
from volpack.volume_codec import stream

GOLDEN = os.path.join(os.path.dirname(__file__), "..", "..", "formats", "examples")


def rgb(shape=(10, 26, 30), seed=0):
    """A smooth field through a colour map: three correlated channels, last."""
    v = smooth_volume(shape, np.int16, seed).astype(np.float64)
    v = (v - v.min()) / (v.max() - v.min())
    return (np.stack([v**0.6, v, v**1.6], -1) * 255).astype(np.uint8)


def two_channels(shape=(10, 26, 30)):
    """Two unrelated channels (nuclei and membranes, say), uint16, last."""
    return np.stack(
        [smooth_volume(shape, np.int16, 1), smooth_volume(shape, np.int16, 2)[::-1]], -1
    ).astype(np.uint16)


def header(blob):
    with Reader(blob) as r:
        return r.header


@pytest.mark.parametrize("make", [rgb, two_channels])
def test_channels_last_round_trip_with_frames_and_regions(make):
    a = make()
    blob = api.compress_array(a, brick=16, tuples=False)
    assert header(blob)["channels"] == "last" and header(blob)["shape"] == list(a.shape)
    back = api.decompress_array(blob)
    assert back.shape == a.shape and back.dtype == a.dtype
    np.testing.assert_array_equal(back, a)
    np.testing.assert_array_equal(stream.decompress(blob, frame=1).data, a[..., 1])
    np.testing.assert_array_equal(
        stream.decompress(blob, roi="2:7,3:20,5:29").data, a[2:7, 3:20, 5:29]
    )


def test_channels_last_codes_shorter_than_a_series_of_thin_volumes():
    a = rgb((12, 40, 44))
    now = len(api.compress_array(a, tuples=False))
    before = len(api.compress_array(a, channels_last=False))
    assert "channels" not in header(api.compress_array(a, channels_last=False))
    assert now < 0.9 * before, (now, before)


def test_channels_last_under_an_error_bound_keeps_the_bound():
    a = rgb().astype(np.float32) / 7
    blob = api.compress_array(a, rel_error=1e-3)
    assert header(blob)["channels"] == "last"
    back = api.decompress_array(blob)
    assert back.shape == a.shape
    assert np.abs(back - a).max() <= 1e-3 * float(a.max() - a.min()) * (1 + 1e-6)


def test_a_series_is_not_taken_for_channels():
    s = np.stack([smooth_volume((6, 20, 18), np.int16, t) for t in range(3)])  # x of 18
    assert "channels" not in header(api.compress_array(s))
    thin = rgb((3, 20, 18))  # a last axis of 3 but a first of 3 too: a series, as before
    assert "channels" not in header(api.compress_array(thin))
    assert header(api.compress_array(thin, channels_last=True, tuples=False))["channels"] == "last"


def test_channels_last_is_refused_where_it_cannot_apply():
    with pytest.raises(OptionError, match="channels_last: a 4-D .* found 3 axes"):
        api.compress_array(rgb()[..., 0], channels_last=True)


def test_a_psnr_target_is_searched_on_the_channels_as_stored():
    a = rgb().astype(np.float32) / 3
    buf = io.BytesIO()
    st = stream.compress(a, buf, psnr=40)
    blob = buf.getvalue()
    assert header(blob)["channels"] == "last"
    back = api.decompress_array(blob)
    assert back.shape == a.shape
    mse = np.mean((back.astype(np.float64) - a) ** 2)
    reached = 10 * np.log10(float(a.max() - a.min()) ** 2 / mse)
    assert abs(reached - 40) <= 0.5 and abs(st["search"]["reached"] - reached) < 0.01


def test_a_damaged_channels_key_is_refused_in_one_line():
    blob = api.compress_array(rgb(), brick=16, tuples=False)
    with pytest.raises(FormatError, match="expected channels 'last' of a 4-D volume"):
        api.decompress_array(rewrite_header(blob, channels="first"))
    flat = api.compress_array(rgb()[..., 0], brick=16)
    with pytest.raises(FormatError, match="expected channels 'last' of a 4-D volume"):
        api.decompress_array(rewrite_header(flat, channels="last"))


def test_the_command_line_says_so_and_gives_the_same_array_back(tmp_path):
    from click.testing import CliRunner

    from volpack.cli import main

    def run(*args):
        return CliRunner().invoke(main, [str(x) for x in args], catch_exceptions=False)

    a = rgb()
    np.save(tmp_path / "c.npy", a)
    r = run("compress", tmp_path / "c.npy", tmp_path / "c.vpk")
    assert r.exit_code == 0 and "the last axis as channels" in r.output, r.output
    r = run("info", tmp_path / "c.vpk")
    assert "last: (z, y, x, c)" in r.output, r.output
    r = run("decompress", tmp_path / "c.vpk", tmp_path / "back.npy")
    assert r.exit_code == 0, r.output
    np.testing.assert_array_equal(np.load(tmp_path / "back.npy"), a)


def golden_rgb():
    """scripts/make_examples.py's recipe 'rgb-u8', written out again on purpose."""
    from volpack.demo import load_demo_volume

    cut = load_demo_volume().data[30:50, 40:64, 40:68].astype(np.float64) / 255
    return (np.stack([cut**0.6, cut, cut**1.6], -1) * 255).astype(np.uint8)


def test_golden_channels_stream_decodes_and_is_reproduced():
    with open(os.path.join(GOLDEN, "lossless-channels-rgb-u8.vpk"), "rb") as f:
        blob = f.read()
    want = golden_rgb()
    assert header(blob)["channels"] == "last"
    np.testing.assert_array_equal(api.decompress_array(blob), want)
    again = api.compress_array(want, brick=32, tuples=False)
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]


def test_complex_and_2d_arrays_are_refused_with_what_to_do(tmp_path):
    from volpack import io as vio

    k = np.fft.fftn(rgb()[..., 0].astype(np.float32)).astype(np.complex64)
    np.save(tmp_path / "k.npy", k)
    with pytest.raises(FormatError, match=r"two channels, np.stack\(\[a.real, a.imag\], -1\)"):
        vio.read_volume(str(tmp_path / "k.npy"))
    parts = np.stack([k.real, k.imag], -1)  # what the message says: a (z, y, x, 2) volume
    blob = api.compress_array(parts)
    assert header(blob)["channels"] == "last"
    back = api.decompress_array(blob)
    assert back.tobytes() == parts.tobytes()
    np.save(tmp_path / "flat.npy", rgb()[0, :, :, 0])
    with pytest.raises(FormatError, match=r"a volume of one slice: a\[None\]"):
        vio.read_volume(str(tmp_path / "flat.npy"))
    np.save(tmp_path / "line.npy", rgb()[0, 0, :, 0])
    with pytest.raises(FormatError, match=r"a volume of one row: a\[None, None\]"):
        vio.read_volume(str(tmp_path / "line.npy"))


def test_the_command_line_decides_channels_both_ways(tmp_path):
    from click.testing import CliRunner

    from volpack.cli import main

    np.save(tmp_path / "rgb.npy", rgb())
    for flag, want in (([], "last"), (["--no-channels-last"], None)):
        out = tmp_path / f"o{len(flag)}.vpk"
        r = CliRunner().invoke(main, ["compress", str(tmp_path / "rgb.npy"), str(out), *flag])
        assert r.exit_code == 0, r.output
        got = header(out.read_bytes()).get("channels")
        assert (got["axis"] if isinstance(got, dict) else got) == want  # (a tuple palette)
        np.testing.assert_array_equal(api.decompress_array(out.read_bytes()), rgb())
    r = CliRunner().invoke(main, ["compress", str(tmp_path / "rgb.npy"), str(tmp_path / "g.vpk"),
                                  "--channels-last", "--gop", "IPP"])  # fmt: skip
    assert r.exit_code == 2 and "--channels-last applies to a 4-D volume" in r.output


def test_info_of_a_source_file_names_the_axes_as_compress_takes_them(tmp_path):
    from click.testing import CliRunner

    from volpack.cli import main

    np.save(tmp_path / "rgb.npy", rgb())
    np.save(tmp_path / "series.npy", np.zeros((3, 6, 20, 18), np.int16))
    r = CliRunner().invoke(main, ["info", str(tmp_path / "rgb.npy")])
    assert r.exit_code == 0 and "(z, y, x, c): channels, as compress takes them" in r.output
    r = CliRunner().invoke(main, ["info", str(tmp_path / "series.npy")])
    assert r.exit_code == 0 and "3 x 6 x 20 x 18  (t, z, y, x)" in r.output
