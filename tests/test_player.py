"""``volpack play``: the playback schedule end to end, movies out, damaged streams."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import need

from volpack import synth
from volpack.animation import player
from volpack.animation import stream as animation
from volpack.cli import main
from volpack.errors import FormatError

# slow: decodes animations: the animation kernels compile (pytest -m slow runs them; .ci/run does)
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def anim(tmp_path_factory):
    """A 7-frame IBBP animation of the bundled MRI moving by sub-voxel steps."""
    d = tmp_path_factory.mktemp("anim")
    frames = synth.translate(synth.head((24, 28, 28)), 7, (0.5, 0.25, -0.75))
    path = d / "run.vpk"
    animation.compress(frames, str(path), gop_string="IBBP", max_error=1)
    return path, frames


def test_play_follows_the_schedule_and_reproduces_every_frame(anim):
    path, frames = anim
    with animation.AnimationReader(str(path)) as r:
        want = r.frames()
        types = r.types
    got = list(player.play(str(path)))
    assert [st.t for _, st, _ in got] == list(range(len(frames)))
    for frame, st, _ in got:
        assert np.array_equal(frame, want[st.t])
        assert st.type in "IPB" and st.nbytes > 0
    assert np.abs(want.astype(float) - frames.astype(float)).max() <= 1
    assert [st.type for _, st, _ in got][0] == types[0] == "I"


def test_cli_play_writes_gif_and_folder_and_stats(anim, tmp_path):
    from PIL import Image

    path, frames = anim
    run = CliRunner().invoke
    r = run(main, ["play", str(path), str(tmp_path / "a.gif"), "--size", "32x24", "--fps", "10",
                   "--spin", "5", "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    rep = json.loads(r.stdout)
    assert rep["frames"] == len(frames) and len(rep["per_frame"]) == len(frames)
    assert all(f["decode_ms"] >= 0 and f["render_ms"] > 0 for f in rep["per_frame"])
    with Image.open(tmp_path / "a.gif") as im:
        assert im.n_frames == len(frames) and im.size == (32, 24)
    r = run(main, ["play", str(path), str(tmp_path / "seq"), "--size", "16x16"])
    assert r.exit_code == 0, r.output
    assert len(list((tmp_path / "seq").glob("frame_*.png"))) == len(frames)
    r = run(main, ["play", str(path), "--stats", "--size", "16x16"])
    assert r.exit_code == 0, r.output
    assert "decode ms" in r.stdout and len(r.stdout.strip().splitlines()) == len(frames) + 2


def test_mp4_output(anim, tmp_path):
    need("imageio_ffmpeg", "video")
    path, frames = anim
    r = CliRunner().invoke(main, ["play", str(path), str(tmp_path / "a.mp4"), "--size", "32x32"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "a.mp4").stat().st_size > 100


def test_truncated_stream_plays_up_to_the_damage(anim, tmp_path):
    path, frames = anim
    data = path.read_bytes()
    cut = tmp_path / "cut.vpk"
    cut.write_bytes(data[: len(data) * 2 // 3])
    shown = []
    with pytest.raises(FormatError, match="frame"):
        for _, st, _ in player.play(str(cut)):
            shown.append(st.t)
    assert 1 <= len(shown) < len(frames)
    r = CliRunner().invoke(main, ["play", str(cut), str(tmp_path / "x.gif"), "--size", "8x8"])
    assert r.exit_code == 1 and "frame" in r.output
    assert not (tmp_path / "x.gif").exists()


def test_one_frame_animation(tmp_path):
    path = tmp_path / "one.vpk"
    animation.compress(synth.head((8, 8, 8))[None], str(path), gop_string="IPP")
    got = list(player.play(str(path)))
    assert len(got) == 1 and got[0][1].type == "I"
