"""What a new user met on the command line (session 27, results/cli/user27/findings.md):
each test failed before its fix."""

from __future__ import annotations

import errno
import json
import os
from pathlib import Path

import numpy as np
import pytest
from cli_user import one_error_line, run, small_npy
from click.testing import CliRunner

from volpack.cli import main

EXAMPLES = Path(__file__).resolve().parents[2] / "formats" / "examples"
VOLUME_VPK = EXAMPLES / "lossless-auto-u8.vpk"  # a golden stream of kind "volume"


@pytest.fixture
def npy(tmp_path) -> Path:
    return small_npy(tmp_path)


@pytest.mark.parametrize("name", ["out.nii.gz", "out.npy", "out.h5:/x", "out.tif", "out.vtu"])
def test_compress_refuses_a_target_named_as_another_format(npy, tmp_path, name):
    # it wrote a .vpk called out.nii.gz, which every other program then failed to open
    r = run("compress", npy, tmp_path / name)
    assert r.exit_code == 1
    assert "expected a TARGET ending in .vpk" in one_error_line(r) and name in r.stderr
    assert sorted(os.listdir(tmp_path)) == ["a.npy"]


def test_render_refuses_an_output_that_is_not_a_png(tmp_path):
    # it wrote PNG bytes into r.jpg (play and walk already refused a wrong suffix)
    for name in ("r.jpg", "r.npy"):
        r = run("render", VOLUME_VPK, tmp_path / name)
        assert r.exit_code == 1 and "expected an OUTPUT ending in .png" in one_error_line(r)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("keep", [0, 30, 200])
def test_a_damaged_vpk_reports_its_damage_in_info_convert_and_compare(tmp_path, keep):
    # info said "expected a volume file, found the .vpk ...: read it with
    # volpack.read_volume", as if the file were fine, for an empty or truncated .vpk
    bad = tmp_path / "cut.vpk"
    bad.write_bytes(VOLUME_VPK.read_bytes()[:keep])
    for args in (["info", bad], ["convert", bad, tmp_path / "o.npy"], ["compare", bad]):
        r = run(*args)
        line = one_error_line(r)
        assert r.exit_code == 1 and "truncated" in line and "read_volume" not in line, line
    assert sorted(os.listdir(tmp_path)) == ["cut.vpk"]


def test_a_full_disk_names_the_output(npy, tmp_path, monkeypatch):
    # "volpack: error: [Errno 28] No space left on device", naming no file
    import volpack.format.atomic as atomic

    real = os.fdopen

    class Full:  # a file on a full disk: every write fails
        def __init__(self, fd, mode):
            self.f = real(fd, mode)

        def write(self, data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

        def __getattr__(self, name):
            return getattr(self.f, name)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.f.close()

    monkeypatch.setattr(atomic.os, "fdopen", Full)
    target = tmp_path / "o.vpk"
    r = run("compress", npy, target)
    assert r.exit_code == 1
    assert one_error_line(r) == f"volpack: error: {target}: No space left on device"
    assert not target.exists()


def test_play_of_a_vpk_of_another_kind_says_so(tmp_path):
    # it listed the animation header's keys against the volume header's; since session 32
    # a 4-D volume plays its time steps, and a 3-D one is refused with a pointer to render
    r = run("play", VOLUME_VPK, tmp_path / "p.gif")
    assert r.exit_code == 1
    line = one_error_line(r)
    assert line.startswith(
        "volpack: error: expected an animation, a 4-D (t, z, y, x) series or a netCDF "
        "variable (time, y, x) to play, found a volume of shape ["
    ) and line.endswith(
        f"in {VOLUME_VPK} (to turn about it: volpack render SOURCE OUT_DIR --orbit N)"
    )
    octree = EXAMPLES / "octree-bounded-u8.vpk"
    r = run("play", octree, tmp_path / "p.gif")
    assert r.exit_code == 1 and one_error_line(r) == (
        "volpack: error: expected an animation or a 4-D (t, z, y, x) series, found a .vpk of "
        f"kind 'octree' in {octree} (volpack render draws it)"
    )
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize(
    "args",
    [
        ["compress", "{npy}", "-"],
        ["decompress", VOLUME_VPK, "-"],
        ["convert", "{npy}", "-"],
        ["render", VOLUME_VPK, "-"],
    ],
)
def test_json_and_an_output_on_standard_output_are_refused_together(npy, args):
    # the JSON followed the stream on stdout: `compress a.npy - --json | decompress - b.npy`
    # failed with "expected the end of the stream after the footer, found b'{'"
    r = run(*[str(a).format(npy=npy) for a in args], "--json")
    assert r.exit_code == 2 and "expected --json or an output of '-'" in r.stderr
    assert r.stdout == ""


def test_json_errors_are_json_on_standard_output(npy, tmp_path):
    # an error printed nothing on stdout: `volpack info x --json | jq` had nothing to parse
    for args in (
        ["info", tmp_path / "nope.npy"],
        ["compress", tmp_path / "nope.npy", tmp_path / "o.vpk"],
        ["decompress", npy, tmp_path / "o.npy"],
    ):
        r = run(*args, "--json")
        assert r.exit_code == 1
        line = one_error_line(r)
        assert json.loads(r.stdout) == {"error": line.removeprefix("volpack: error: ")}
    r = run("info", npy, "--json")  # and a success is as before
    assert r.exit_code == 0 and json.loads(r.stdout)["shape"] == [4, 5, 6]


def test_convert_never_overwrites_a_raw_input_as_a_metaimage_data_file(tmp_path):
    # s.mhd is written with its data in s.raw: with --force that replaced the raw input
    # (here byte-swapped); without it, the error named s.raw as an existing output
    raw = tmp_path / "s.raw"
    np.arange(60, dtype=">i2").reshape(3, 4, 5).tofile(raw)
    before = raw.read_bytes()
    r = run("convert", raw, tmp_path / "s.mhd", "--shape", "3,4,5", "--dtype", "int16",
            "--byteorder", "big", "--force")  # fmt: skip
    last = r.stderr.splitlines()[-1]  # after the line that echoes the raw shape
    assert r.exit_code == 1 and last.startswith("volpack: error: refusing to overwrite the input")
    assert raw.read_bytes() == before and sorted(os.listdir(tmp_path)) == ["s.raw"]
    r = run("convert", raw, tmp_path / "t.mhd", "--shape", "3,4,5", "--dtype", "int16",
            "--byteorder", "big")  # fmt: skip
    assert r.exit_code == 0 and (tmp_path / "t.raw").read_bytes() != before  # little-endian


def test_a_vpk_stream_on_standard_input_converts(tmp_path):
    # 'volpack --help' says '-' takes npy or vpk streams, but convert, compare and render
    # took only npy: "expected a .npy stream on standard input, found ... b'VPK..."
    r = CliRunner().invoke(main, ["convert", "-", str(tmp_path / "a.npy")],
                           input=VOLUME_VPK.read_bytes())  # fmt: skip
    assert r.exit_code == 0, r.output
    assert run("decompress", VOLUME_VPK, tmp_path / "b.npy").exit_code == 0
    np.testing.assert_array_equal(np.load(tmp_path / "a.npy"), np.load(tmp_path / "b.npy"))


def test_the_first_compile_notice_does_not_say_first_run_on_this_machine():
    # after an upgrade (or an edit of the sources) the cache is new and the notice said
    # "first run on this machine" on a machine that had run volpack for months
    from volpack.cli.notices import FIRST_RUN

    line = FIRST_RUN.format(what="k", where="/c")
    assert "this machine" not in line and "empty kernel cache" in line and "/c" in line


def test_decompress_of_a_file_of_another_format_names_the_format(npy, tmp_path):
    # it said which magic bytes the container expected: "expected the vpk magic
    # b'VPK\x00\r\n\x1a\n', found b'\x93NUMPY\x01\x00'"
    r = run("decompress", npy, tmp_path / "o.npy")
    assert r.exit_code == 1 and one_error_line(r) == (
        f"volpack: error: expected a .vpk file, found the npy file '{npy}' "
        "(volpack convert and volpack compress read it)"
    )
    cut = tmp_path / "cut.vpk"  # a damaged .vpk still reports its damage
    cut.write_bytes(VOLUME_VPK.read_bytes()[:200])
    assert "truncated" in one_error_line(run("decompress", cut, tmp_path / "o.npy"))


def write_inv3(path: Path, array: np.ndarray, spacing_xyz, extra: bytes = b"") -> None:
    """An InVesalius project as InVesalius 3 writes one: main.plist and matrix.dat in a
    folder of a gzip-compressed tar."""
    import io
    import plistlib
    import tarfile

    plist = {"matrix": {"dtype": array.dtype.name, "filename": "matrix.dat",
                        "shape": list(array.shape)},
             "spacing": list(spacing_xyz), "modality": "CT", "name": "test"}  # fmt: skip
    with tarfile.open(path, "w:gz") as tar:
        for name, blob in (("main.plist", plistlib.dumps(plist)),
                           ("matrix.dat", array.astype("<" + array.dtype.str[1:]).tobytes() + extra)):  # fmt: skip
            info = tarfile.TarInfo(f"tmpabc/{name}")
            info.size = len(blob)
            tar.addfile(info, io.BytesIO(blob))


def test_an_invesalius_project_reads_as_its_ct(tmp_path):
    # the head CT of the data folder, Cranium.inv3, was "expected a volume file with one
    # of the extensions ..."; its voxels had to be cut out as raw by hand
    a = (np.arange(3 * 4 * 5, dtype=np.int16) * 37 - 1024).reshape(3, 4, 5)
    write_inv3(tmp_path / "head.inv3", a, (0.5, 0.75, 2.0))
    r = run("info", tmp_path / "head.inv3", "--json")
    d = json.loads(r.stdout)
    assert r.exit_code == 0 and d["format"] == "inv3" and d["shape"] == [3, 4, 5]
    assert d["dtype"] == "int16" and d["spacing"] == [2.0, 0.75, 0.5]  # (z, y, x)
    r = run("convert", tmp_path / "head.inv3", tmp_path / "head.npy")
    assert r.exit_code == 0
    np.testing.assert_array_equal(np.load(tmp_path / "head.npy"), a)
    write_inv3(tmp_path / "long.inv3", a, (1, 1, 1), extra=b"\0\0")
    r = run("info", tmp_path / "long.inv3")
    assert r.exit_code == 1 and "expected 120 bytes of int16 voxels" in one_error_line(r)


# session 28 (results/cli/user28/findings.md)


@pytest.mark.parametrize("command", ["play", "walk"])
def test_play_and_walk_of_a_file_of_another_format_name_the_format(npy, tmp_path, command):
    # they answered with the container's magic bytes: "expected the vpk magic
    # b'VPK\x00\r\n\x1a\n', found b'\x93NUMPY\x01\x00'" (user27's finding 14)
    r = run(command, npy, tmp_path / "o.gif")
    # play takes any 4-D volume file since session 32 (this one is 3-D: refused)
    assert r.exit_code == 1 and one_error_line(r) == (
        f"volpack: error: expected a .vpk file, found the npy file '{npy}' "
        "(volpack convert and volpack compress read it)"
        if command == "walk"
        else "volpack: error: expected an animation, a 4-D (t, z, y, x) series or a netCDF "
        f"variable (time, y, x) to play, found a volume of shape [4, 5, 6] in {npy} (to turn "
        "about it: volpack render SOURCE OUT_DIR --orbit N)"
    )
    assert sorted(os.listdir(tmp_path)) == ["a.npy"]


@pytest.mark.parametrize("command", ["info", "decompress", "compare", "play", "walk"])
def test_a_damaged_vpk_is_named_before_its_damage(tmp_path, command):
    # "expected 248 bytes of header at offset 20, found 180 (truncated)": which file?
    # (user27's finding 14; the library's message is unchanged, the CLI names the file)
    from volpack.errors import FormatError
    from volpack.format.container import Reader

    cut = tmp_path / "cut.vpk"
    cut.write_bytes(VOLUME_VPK.read_bytes()[:200])
    with pytest.raises(FormatError) as e:
        Reader(cut)
    args = [command, cut] + ([tmp_path / "o.npy"] if command == "decompress" else [])
    r = run(*args, "--json")
    line = one_error_line(r)
    assert r.exit_code == 1 and line.startswith(f"volpack: error: {cut}: "), line
    assert "truncated" in line and line.count(str(cut)) == 1
    assert json.loads(r.stdout) == {"error": line.removeprefix("volpack: error: ")}
    if command != "play":  # (play reads the file as a stream: its message differs)
        assert line == f"volpack: error: {cut}: {e.value}"
    assert str(cut) not in str(e.value) and e.value.path == str(cut)


def test_a_damaged_chunk_names_its_file(tmp_path):
    # a chunk whose bytes no longer match their checksum: the file is named once
    blob = bytearray(VOLUME_VPK.read_bytes())
    blob[400] ^= 0xFF  # inside the first chunk's payload
    bad = tmp_path / "bad.vpk"
    bad.write_bytes(bytes(blob))
    r = run("decompress", bad, tmp_path / "o.npy")
    line = one_error_line(r)
    assert r.exit_code == 1 and line.startswith(f"volpack: error: {bad}: ") and "CRC" in line
    assert line.count(str(bad)) == 1


@pytest.mark.parametrize("dtype", ["uint8", "int16", "float32"])
def test_an_error_bound_of_0_is_coded_losslessly(tmp_path, dtype):
    # --max-error 0 wrote the bounded codec's quantised voxels: 402 kB against 391 kB
    # lossless on brainsmall (user27's finding 20); on floats it was refused
    z, y, x = np.mgrid[:24, :26, :28]
    noise = np.random.default_rng(5).normal(0, 3, z.shape)
    a = (60 * np.sin(x / 5) * np.cos(y / 4) + 2 * z + noise + 100).astype(dtype)
    src = tmp_path / "a.npy"
    np.save(src, a)
    assert run("compress", src, tmp_path / "lossless.vpk").exit_code == 0
    size = (tmp_path / "lossless.vpk").stat().st_size
    for flags in (["--max-error", "0"], ["--rel-error", "0"]):
        out = tmp_path / "zero.vpk"
        r = run("compress", src, out, "--force", *flags, "--json")
        assert r.exit_code == 0, r.output
        assert json.loads(r.stdout)["codec"]["id"] == "lossless"
        assert out.stat().st_size <= size
        assert run("decompress", out, tmp_path / "b.npy", "--force").exit_code == 0
        assert np.load(tmp_path / "b.npy").tobytes() == a.tobytes()


def test_serve_status_without_a_server_exits_1(tmp_path, monkeypatch):
    # it printed "no server listens on ..." and exited 0, so `volpack serve --status &&
    # ...` went on as if one listened (user27's finding 18)
    monkeypatch.setenv("VOLPACK_SERVE_DIR", str(tmp_path))
    r = run("serve", "--status")
    assert r.exit_code == 1 and r.stdout.startswith("no server listens on ")
    r = run("serve", "--status", "--json")
    d = json.loads(r.stdout)
    assert r.exit_code == 1 and d["listening"] is False and "no server listens" in d["error"]
    assert run("serve", "--stop").exit_code == 0  # nothing to stop is no failure


# slow set: the only fast user of its kernel signatures (session 34, scripts/pytest_kerneluse.py)
@pytest.mark.slow
def test_walk_counts_the_nodes_decoded_before_its_frames(tmp_path):
    # brainsmall as an octree: "120 frames, 1.85 frames/s, 0 nodes decoded" (user27's
    # finding 22): a tree this small is decoded whole as the coarse level (for the
    # transfer function and the framing) before the first frame, so no frame decodes
    z, y, x = np.mgrid[:40, :36, :32]
    a = (100 + 80 * np.sin(x / 4) * np.cos(y / 5) + z).astype(np.uint8)
    np.save(tmp_path / "a.npy", a)
    tree = tmp_path / "t.vpk"
    assert run("compress", tmp_path / "a.npy", tree, "--octree").exit_code == 0
    r = run("walk", tree, "--orbit", "2", "--size", "16x16", "--json")
    assert r.exit_code == 0, r.output
    d = json.loads(r.stdout)
    frames = sum(f["decoded"] for f in d["per_frame"])
    assert d["decoded_before"] > 0 and frames == 0  # every node came from the coarse level
    from volpack.octree import Octree

    with Octree(tree) as t:  # what decoding the whole tree counts
        t.decode(0)
        assert d["decoded_before"] == t.decoded_nodes
    r = run("walk", tree, "--orbit", "2", "--size", "16x16")
    assert r.exit_code == 0
    assert f"0 nodes decoded in the frames, {d['decoded_before']} before them" in r.stderr


def test_a_manifest_saved_by_excel_is_read(npy, tmp_path):
    # Excel's "CSV UTF-8" starts with a byte-order mark (and ends lines with CRLF):
    # "expected an 'input' in every row of 'm.csv', row 1 has none"
    man = tmp_path / "m.csv"
    man.write_bytes(b"\xef\xbb\xbfinput,max_error\r\na.npy,0.5\r\n")
    r = run("batch", man, tmp_path / "out")
    assert r.exit_code == 0, r.output
    assert (tmp_path / "out" / "a.vpk").is_file()
    js = tmp_path / "m.json"
    js.write_bytes(b'\xef\xbb\xbf[{"input": "a.npy", "output": "b.vpk"}]')
    assert run("batch", js, tmp_path / "out").exit_code == 0
    assert (tmp_path / "out" / "b.vpk").is_file()


def test_a_manifest_output_named_as_another_format_is_refused(npy, tmp_path):
    # a row 'a.npy,a.nii.gz' wrote a .vpk called a.nii.gz (as compress did, user27's 1)
    man = tmp_path / "m.csv"
    man.write_text("input,output\na.npy,a.nii.gz\n")
    r = run("batch", man, tmp_path / "out")
    assert r.exit_code == 1
    assert "expected a manifest's output ending in .vpk" in one_error_line(r)
    assert "a.nii.gz" in r.stderr and not (tmp_path / "out" / "a.nii.gz").exists()


def test_a_manifest_column_of_no_option_lists_the_columns(npy, tmp_path):
    # "expected options among codec, ..., --levels, brick, --max-error, ...": the CLI
    # rewrote some of the column names into flags, which no manifest column is
    man = tmp_path / "m.csv"
    man.write_text("input,maxerror\na.npy,1\n")
    line = one_error_line(run("batch", man, tmp_path / "out"))
    assert "'max_error'" in line and "'max_levels'" in line and "--" not in line, line


def _examples(name: str) -> list[list[str]]:
    """The arguments of the ``volpack NAME ...`` lines in NAME's --help, without their
    trailing comments and the shell around them (pipes, redirections)."""
    import shlex

    import click

    cmd = main.get_command(None, name)
    out = []
    for line in cmd.get_help(click.Context(cmd, info_name=name)).splitlines():
        s = line.strip()
        if s.startswith(f"volpack {name} "):
            s = s.split("   ")[0].split(" # ")[0].split(" | ")[0].split(" > ")[0]
            out.append(shlex.split(s)[2:])
    return out


def test_every_help_example_parses():
    # each command's --help examples, parsed by the command's own options (no file is
    # read): a renamed flag or choice left in an example fails here
    import click

    names = [n for n in main.list_commands(None) if _examples(n)]
    assert len(names) >= 10
    for name in names:
        for args in _examples(name):
            try:
                main.get_command(None, name).make_context(name, list(args))
            except click.ClickException as e:
                raise AssertionError(
                    f"volpack {name} {' '.join(args)}: {e.format_message()}"
                ) from None


def test_a_bound_under_1_on_integers_is_exact_from_the_command_line_too(tmp_path):
    # the library codes an integer volume under a bound below 1 exactly (no coding but
    # the exact one meets it); the command line passed its --wavelet and --order
    # defaults as if asked for, which kept the bounded codec: brainsmall at --max-error
    # 0.5 gave 402,384 B against 390,835 B lossless
    z, y, x = np.mgrid[:24, :26, :28]
    noise = np.random.default_rng(6).normal(0, 3, z.shape)
    a = (60 * np.sin(x / 5) * np.cos(y / 4) + 2 * z + noise + 100).astype(np.uint8)
    np.save(tmp_path / "a.npy", a)
    assert run("compress", tmp_path / "a.npy", tmp_path / "l.vpk").exit_code == 0
    r = run("compress", tmp_path / "a.npy", tmp_path / "h.vpk", "--max-error", "0.5", "--json")
    assert r.exit_code == 0 and json.loads(r.stdout)["codec"]["id"] == "lossless"
    assert (tmp_path / "h.vpk").read_bytes() == (tmp_path / "l.vpk").read_bytes()
    r = run("compress", tmp_path / "a.npy", tmp_path / "w.vpk", "--max-error", "0.5",
            "--wavelet", "53", "--json")  # fmt: skip
    assert r.exit_code == 0 and json.loads(r.stdout)["codec"]["id"] == "bounded"  # as asked


@pytest.mark.parametrize(
    "field, value",
    [("search", "junk"), ("search.reached", "x"), ("error_bound", "e"), ("rmse", [2]),
     ("tools", "t"), ("psnr", {})],
)  # fmt: skip
def test_info_shows_a_file_whose_summary_is_damaged(tmp_path, field, value):
    """Session 39: `volpack info` (text) formatted the summary's fields as they came, and
    a summary field of another type (`search` a string, `reached` a string) was an
    internal error; the fuzzer runs `info --json`, which does not format them."""
    from conftest import rewrite_header

    from volpack import api
    from volpack.format.container import Reader

    z, y, x = np.mgrid[:16, :16, :16]
    a = np.where(x + y > 14, 1.0, 2.7).astype(np.float32) + 0.01 * (z % 3)
    blob = api.compress_array(a, psnr=40)
    with Reader(blob) as r:
        summary = dict(r.summary)
    assert isinstance(summary.get("search"), dict)  # the field the first cases damage
    key, _, sub = field.partition(".")
    summary[key] = {**summary[key], sub: value} if sub else value
    path = tmp_path / "damaged.vpk"
    path.write_bytes(rewrite_header(blob, summary=summary))
    r = CliRunner().invoke(main, ["info", str(path)])
    assert r.exit_code == 0 and "internal error" not in r.output, r.output
    assert "ratio" in r.output
