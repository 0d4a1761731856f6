"""``volpack play`` of a 4-D series that is not an animation: a volume .vpk (stored frame by
frame or interleaved, from a file or a pipe) or any 4-D volume file."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import smooth_volume

from volpack import api
from volpack.animation import player
from volpack.cli import main
from volpack.errors import FormatError


@pytest.fixture(scope="module")
def run4d(tmp_path_factory):
    """A 5-step series of one anatomy with fresh noise (interleaving pays), as .npy and as
    volume .vpk files stored both ways."""
    d = tmp_path_factory.mktemp("series")
    a = np.stack([smooth_volume((6, 20, 18), np.int16, seed=s, noise=3.0) for s in range(5)])
    np.save(d / "s.npy", a)
    for name, opt in (("frames", False), ("inter", True)):
        api.compress(a, str(d / f"{name}.vpk"), interleave=opt)
    return d, a


@pytest.mark.parametrize("name", ["frames", "inter"])
def test_a_volume_vpk_plays_its_time_steps(run4d, name):
    d, a = run4d
    assert api.info(str(d / f"{name}.vpk"))["header"].get("layout") == (
        "interleaved" if name == "inter" else None
    )
    got = list(player.play(str(d / f"{name}.vpk")))
    assert [st.t for _, st, _ in got] == list(range(5))
    for frame, st, hdr in got:
        np.testing.assert_array_equal(frame, a[st.t])
        assert st.type == "volume" and hdr["kind"] == "volume"
    nbytes = [st.nbytes for _, st, _ in got]
    payload = api.info(str(d / f"{name}.vpk"))["summary"]["payload_nbytes"]
    if name == "frames":  # each time step's own chunks
        assert sum(nbytes) == payload and min(nbytes) > 0
        assert all(st.decode_ms > 0 for _, st, _ in got)
    else:  # decoded whole before the first frame: a share each
        assert abs(sum(nbytes) - payload) < 5
        assert got[0][1].decode_ms > 0 and all(st.decode_ms == 0 for _, st, _ in got[1:])


def test_any_4d_file_plays_and_a_3d_one_is_refused(run4d, tmp_path):
    d, a = run4d
    got = list(player.series(str(d / "s.npy")))
    assert len(got) == 5 and all(np.array_equal(f, a[st.t]) for f, st, _ in got)
    h5py = pytest.importorskip("h5py")
    with h5py.File(tmp_path / "s.h5", "w") as f:  # a file:dataset spec
        f["ds"] = a
    got = list(player.play(f"{tmp_path / 's.h5'}:/ds"))
    assert len(got) == 5 and all(np.array_equal(f, a[st.t]) for f, st, _ in got)
    assert sum(st.nbytes for _, st, _ in got) <= (tmp_path / "s.h5").stat().st_size
    np.save(tmp_path / "one.npy", a[0])
    with pytest.raises(FormatError, match=r"4-D \(t, z, y, x\) series or a netCDF variable "
                       r"\(time, y, x\) to play, found a volume of shape \[6, 20, 18\]"):  # fmt: skip
        list(player.play(str(tmp_path / "one.npy")))
    api.compress(a[0], str(tmp_path / "one.vpk"))
    with pytest.raises(FormatError, match="found a volume of shape"):
        list(player.play(str(tmp_path / "one.vpk")))


# slow set: the only fast user of its kernel signatures (session 34, scripts/pytest_kerneluse.py)
@pytest.mark.slow
def test_cli_plays_a_series_from_a_file_and_from_a_pipe(run4d, tmp_path):
    from PIL import Image

    d, a = run4d
    run = CliRunner().invoke
    r = run(main, ["play", str(d / "inter.vpk"), str(tmp_path / "s.gif"), "--size", "24x16",
                   "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    rep = json.loads(r.stdout)
    assert rep["frames"] == 5 and [f["type"] for f in rep["per_frame"]] == ["volume"] * 5
    with Image.open(tmp_path / "s.gif") as im:
        assert im.n_frames == 5 and im.size == (24, 16)
    # standard input: a volume .vpk or a .npy stream (the frame count not known ahead)
    for src in ("frames.vpk", "s.npy"):
        r = run(main, ["play", "-", "--size", "16x16", "--json"],
                input=(d / src).read_bytes())  # fmt: skip
        assert r.exit_code == 0, (src, r.output)
        assert json.loads(r.stdout)["frames"] == 5
