"""Frame sequences out (volpack.render.movie): MP4, GIF and PNG folders read back."""

from __future__ import annotations

import os

import numpy as np
import pytest
from conftest import need

from volpack.errors import VolpackError
from volpack.render.movie import MovieWriter, movie_kind


def frames(n=5, h=21, w=33):
    """Frames whose grey level encodes their index, pre-multiplied RGBA."""
    out = []
    for k in range(n):
        img = np.zeros((h, w, 4), np.float32)
        img[..., :3] = 0.1 + 0.8 * k / max(n - 1, 1)
        img[..., 3] = 1.0
        out.append(img)
    return out


def test_kinds():
    assert movie_kind("a.mp4") == "mp4" and movie_kind("a.GIF") == "gif"
    assert movie_kind("frames/") == "png" and movie_kind("frames") == "png"
    with pytest.raises(VolpackError, match="mp4 or .gif"):
        movie_kind("a.avi")


def test_mp4_round_trip(tmp_path):
    imageio_ffmpeg = need("imageio_ffmpeg", "video")
    target = tmp_path / "run.mp4"
    with MovieWriter(target, fps=10) as mw:
        for f in frames():
            mw.write(f)
    # ffmpeg decodes the file to raw RGB (its pipes closed here, not by the collector)
    import subprocess

    raw = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-i", str(target), "-f", "rawvideo",
         "-pix_fmt", "rgb24", "-"], check=True, capture_output=True,
    ).stdout  # fmt: skip
    assert len(raw) % (22 * 34 * 3) == 0  # padded to even sizes
    got = list(np.frombuffer(raw, np.uint8).reshape(-1, 22, 34, 3))
    assert len(got) == 5
    want = [np.rint(255 * (0.1 + 0.8 * k / 4)) for k in range(5)]
    for g, level in zip(got, want):
        assert abs(float(g[:21, :33].mean()) - level) < 4  # lossy, but the levels survive
    assert [p for p in os.listdir(tmp_path) if p.startswith(".volpack-")] == []


def test_gif_and_png_folder(tmp_path):
    from PIL import Image

    with MovieWriter(tmp_path / "run.gif", fps=20) as mw:
        for f in frames():
            mw.write(f)
    with Image.open(tmp_path / "run.gif") as im:
        assert im.n_frames == 5 and im.size == (33, 21)
        assert im.info["duration"] == 50
    with MovieWriter(tmp_path / "seq", fps=20) as mw:
        for f in frames(3):
            mw.write(f)
    names = sorted(os.listdir(tmp_path / "seq"))
    assert names == ["frame_00000.png", "frame_00001.png", "frame_00002.png"]
    got = np.asarray(Image.open(tmp_path / "seq" / names[2]))
    assert got.shape == (21, 33, 3) and got.min() == got.max() == 230


@pytest.mark.parametrize("name", ["bad.gif", "bad.mp4"])
def test_failures_leave_no_file(tmp_path, name):
    target = tmp_path / name
    with pytest.raises(VolpackError, match="frames of"):
        with MovieWriter(target) as mw:
            mw.write(frames(1)[0])
            mw.write(np.zeros((4, 4, 4), np.float32))
    assert not target.exists()
    with pytest.raises(VolpackError, match="at least one frame"):
        with MovieWriter(target):
            pass
    assert os.listdir(tmp_path) == []
    target.write_bytes(b"old")
    with pytest.raises(VolpackError, match="exists"):
        MovieWriter(target)
    assert target.read_bytes() == b"old"
    with pytest.raises(VolpackError, match="fps"):
        MovieWriter(tmp_path / "x.gif", fps=0)
