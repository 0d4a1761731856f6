"""The command line: every command's --help, the user's commands end to end, exit codes."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import smooth_volume

from volpack.cli import main


def run(*args, input=None, ok=True):
    r = CliRunner().invoke(main, [str(a) for a in args], input=input, catch_exceptions=False)
    if ok:
        assert r.exit_code == 0, (r.output, r.stderr if hasattr(r, "stderr") else "")
    return r


@pytest.mark.parametrize(
    "cmd", [[], ["info"], ["convert"], ["compress"], ["decompress"], ["demo"], ["warmup"], ["serve"]]
)
def test_help_of_every_command(cmd):
    r = run(*cmd, "--help")
    assert "Usage:" in r.output and "Examples" in r.output or cmd in (["demo"], ["warmup"])


def test_help_does_not_import_numba_and_is_fast():
    # CPU seconds, not wall: a loaded machine (CI beside other jobs) stretches wall time.
    code = (
        "import sys, time; t = time.process_time(); from volpack.cli import main\n"
        "from click.testing import CliRunner; r = CliRunner().invoke(main, ['--help'])\n"
        "assert r.exit_code == 0; assert 'numba' not in sys.modules, 'numba imported'\n"
        "assert 'numpy' not in sys.modules, 'numpy imported'\n"
        "print(time.process_time() - t)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert float(out.stdout) < 0.5


def test_the_command_table_names_the_module_of_each_command():
    # commands load lazily from volpack.cli.COMMAND_MODULES: every command of every
    # module must be listed there, under its own module
    import importlib
    import pkgutil

    import volpack.cli as cli

    defined = {}
    for m in pkgutil.iter_modules(cli.__path__):
        for cmd in getattr(importlib.import_module(f"volpack.cli.{m.name}"), "COMMANDS", ()):
            defined[cmd.name] = m.name
    assert defined == cli.COMMAND_MODULES
    assert main.list_commands(None) == sorted(defined)


def test_walk_and_play_import_the_view_options_not_the_render_command(tmp_path):
    # play and walk share the view options with render, which live in cli.view: a walk's
    # start compiles neither the render command's module nor numba's YAML reader
    import volpack

    code = "import sys, volpack.cli.play, volpack._jit; print(sorted(sys.modules))"
    env = dict(os.environ, PYTHONPATH=os.path.dirname(os.path.dirname(volpack.__file__)))
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True,
                         text=True, check=True).stdout  # fmt: skip
    assert "'volpack.cli.view'" in out and "'numba'" in out  # the check can fail
    assert "'volpack.cli.render'" not in out and "'yaml'" not in out


_RENDER_IMPORTS = """
import sys
from volpack.cli import main
try:
    main(["render", sys.argv[1], sys.argv[2], "--force", "--size", "24x20"], standalone_mode=False)
except SystemExit as e:
    assert not e.code, e.code
import gc
assert gc.isenabled() and not gc.get_freeze_count()  # paused for imports only, no freeze
print(" ".join(m for m in sys.argv[3:] if m in sys.modules))
"""


def test_imports_without_gc_pauses_the_collector_and_freezes_in_a_whole_process(monkeypatch):
    import gc

    from volpack.cli import options

    frozen = gc.get_freeze_count()
    with options.imports_without_gc():
        assert not gc.isenabled()
    assert gc.isenabled() and gc.get_freeze_count() == frozen  # a test's process: no freeze
    monkeypatch.setattr(options, "WHOLE_PROCESS", True)  # as volpack.cli.run sets it
    try:
        with options.imports_without_gc():
            keep = [object() for _ in range(10)]  # noqa: F841
        assert gc.isenabled() and gc.get_freeze_count() > frozen
    finally:
        gc.unfreeze()


@pytest.mark.slow  # compiles a render's kernels in a process of its own (25 s)
def test_a_render_imports_neither_other_commands_nor_numbas_compiler(tmp_path):
    """What `volpack render` needs and nothing else: no other command's module, no
    colour-bar drawing, no scipy (numba's version probe), and, with its kernels in the
    cache, none of numba's compiler registries (volpack._jit)."""
    np.save(tmp_path / "a.npy", smooth_volume((12, 13, 14), np.uint8))
    others = [f"volpack.cli.{m}" for m in
              ("batch", "codec", "compare", "convert", "demo", "info", "jit", "play")]  # fmt: skip
    heavy = ["PIL.ImageDraw", "scipy", "matplotlib", "h5py", "tqdm", "volpack.entropy",
             "volpack.volume_codec", "numba.np.arraymath", "numba.typed.dictimpl"]  # fmt: skip
    args = [str(tmp_path / "a.npy"), str(tmp_path / "a.png"), *others, *heavy]
    for _ in range(2):  # the first may compile kernels, the second finds them cached
        out = subprocess.run([sys.executable, "-c", _RENDER_IMPORTS, *args], capture_output=True,
                             text=True, check=True)  # fmt: skip
    from volpack._jit import _KERNEL_CACHE

    loaded = set(out.stdout.split())
    if _KERNEL_CACHE is None:  # kernels load numba's way (no cache, or another numba)
        loaded -= {"numba.np.arraymath", "numba.typed.dictimpl"}
    assert not loaded


_BLAS_IDLE = """
import atexit, os, sys, time
def spent():  # CPU seconds of the threads other than the main one (OpenBLAS's)
    time.sleep(0.15)  # an idle stretch after the command: a polling thread burns it
    main, cpu = str(os.getpid()), 0
    for tid in os.listdir("/proc/self/task"):
        if tid != main:
            with open(f"/proc/self/task/{tid}/schedstat") as f:
                cpu += int(f.read().split()[0])
    print(f"{os.environ.get('OPENBLAS_THREAD_TIMEOUT')} BLAS {cpu / 1e9:.4f}", file=sys.stderr)
atexit.register(spent)
from volpack.launch import run
run()
"""


@pytest.mark.skipif(not os.path.exists("/proc/self/task"), reason="per-thread CPU from /proc")
def test_the_console_entry_keeps_blas_threads_from_polling(tmp_path):
    # numpy's import starts OpenBLAS's threads, which poll for work 0.1 s before they
    # sleep: 0.11 CPU s of every command on this machine. The entry sets their timeout
    # short unless the user chose one, and a command's process then spends (next to)
    # nothing outside its own threads while it idles.
    np.save(tmp_path / "a.npy", smooth_volume((8, 9, 10), np.uint8))
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_THREAD_TIMEOUT"}
    env["VOLPACK_SERVE"] = "0"

    def idle(**more):
        out = subprocess.run([sys.executable, "-c", _BLAS_IDLE, "info", str(tmp_path / "a.npy")],
                             env=dict(env, **more), capture_output=True, text=True,
                             check=True)  # fmt: skip
        timeout, _, cpu = out.stderr.strip().splitlines()[-1].split()
        assert "(8, 9, 10)" in out.stdout or "8" in out.stdout  # the command ran
        return timeout, float(cpu)

    timeout, cpu = idle()
    assert timeout == "4" and cpu < 0.03, (timeout, cpu)
    assert idle(OPENBLAS_THREAD_TIMEOUT="6")[0] == "6"  # the user's choice is kept


def test_python_dash_m_volpack():
    out = subprocess.run(
        [sys.executable, "-m", "volpack", "--version"], capture_output=True, text=True, check=True
    )
    assert "volpack" in out.stdout


def test_console_entry_keeps_exit_codes_and_output(tmp_path):
    """The entry skips module teardown after a command (volpack.cli.run): exit codes and
    everything written must come through as with a normal exit."""

    def vp(*args):
        return subprocess.run([sys.executable, "-m", "volpack", *args], capture_output=True, text=True)

    missing = vp("info", str(tmp_path / "none.vpk"))
    assert missing.returncode == 1 and missing.stderr.startswith("volpack: error:")
    assert vp("info", "--no-such-flag").returncode == 2
    np.save(tmp_path / "a.npy", np.zeros((3, 4, 5), np.uint8))
    ok = vp("info", str(tmp_path / "a.npy"), "--json")
    assert ok.returncode == 0 and json.loads(ok.stdout)["shape"] == [3, 4, 5]


def test_info_on_npy_and_vpk_json(tmp_path):
    a = smooth_volume((10, 11, 12), np.int16)
    np.save(tmp_path / "a.npy", a)
    d = json.loads(run("info", tmp_path / "a.npy", "--json").stdout)
    assert d["shape"] == [10, 11, 12] and d["dtype"] == "int16"
    assert d["min"] == int(a.min()) and d["max"] == int(a.max())
    run("compress", tmp_path / "a.npy", tmp_path / "a.vpk")
    d = json.loads(run("info", tmp_path / "a.vpk", "--json").stdout)
    assert d["format"] == "vpk" and d["chunks"] == 1 and d["ratio"] > 1
    assert 0 < d["chunk_nbytes"]["min"] == d["chunk_nbytes"]["max"]  # one chunk: min is its size
    text = run("info", tmp_path / "a.vpk", "--chunks").output
    assert "ratio" in text and "node" in text
    # the same stream on standard input (its index comes last: it is read whole)
    piped = json.loads(run("info", "-", "--json", input=(tmp_path / "a.vpk").read_bytes()).stdout)
    assert piped["path"] == "-" and piped["file_nbytes"] == d["file_nbytes"]
    assert piped["ratio"] == d["ratio"] and piped["header"] == d["header"]


def test_compress_decompress_roi_and_codec_options(tmp_path):
    a = smooth_volume((40, 50, 60), np.uint16)
    np.save(tmp_path / "a.npy", a)
    run(
        "compress",
        tmp_path / "a.npy",
        tmp_path / "a.vpk",
        "--wavelet",
        "26",
        "--coder",
        "huffman",
        "--brick",
        "16",
        "--workers",
        "2",
    )
    run("decompress", tmp_path / "a.vpk", tmp_path / "b.npy")
    np.testing.assert_array_equal(np.load(tmp_path / "b.npy"), a)
    run("decompress", tmp_path / "a.vpk", tmp_path / "roi.npy", "--roi", "10:20,5:45,:7")
    np.testing.assert_array_equal(np.load(tmp_path / "roi.npy"), a[10:20, 5:45, :7])


def test_existing_output_is_refused_without_force(tmp_path):
    a = smooth_volume((5, 6, 7))
    np.save(tmp_path / "a.npy", a)
    run("compress", tmp_path / "a.npy", tmp_path / "a.vpk")
    before = (tmp_path / "a.vpk").read_bytes()
    r = run("compress", tmp_path / "a.npy", tmp_path / "a.vpk", ok=False)
    assert r.exit_code == 1 and "--force" in r.output
    assert (tmp_path / "a.vpk").read_bytes() == before
    run("compress", tmp_path / "a.npy", tmp_path / "a.vpk", "--force", "--coder", "rle")


def test_input_is_never_overwritten(tmp_path):
    a = smooth_volume((5, 6, 7))
    np.save(tmp_path / "a.npy", a)
    r = run("convert", tmp_path / "a.npy", tmp_path / "a.npy", "--force", ok=False)
    assert r.exit_code == 1 and "input" in r.output
    np.testing.assert_array_equal(np.load(tmp_path / "a.npy"), a)


def test_user_errors_are_one_line_with_exit_1(tmp_path):
    (tmp_path / "bad.vpk").write_bytes(b"\x89VPK\r\n\x1a\nnot really")
    for args in (
        ["info", tmp_path / "nope.npy"],
        ["decompress", tmp_path / "bad.vpk", tmp_path / "o.npy"],
        ["info", tmp_path / "x.unknown"],
    ):
        if args[1].name == "x.unknown":
            args[1].write_bytes(b"123")
        r = run(*args, ok=False)
        assert r.exit_code == 1, r.output
        lines = [ln for ln in r.output.splitlines() if ln.strip()]
        assert len(lines) == 1 and lines[0].startswith("volpack: error: "), r.output
    assert not (tmp_path / "o.npy").exists()


def test_debug_shows_the_traceback(tmp_path):
    r = CliRunner().invoke(main, ["--debug", "info", str(tmp_path / "nope.npy")])
    assert r.exit_code != 0 and r.exception is not None


def test_messages_name_flags_where_the_library_names_parameters(tmp_path):
    np.save(tmp_path / "f.npy", np.linspace(0, 1, 512).reshape(8, 8, 8))
    r = run("compress", tmp_path / "f.npy", tmp_path / "f.vpk", "--quality", "5", ok=False)
    assert r.exit_code == 1 and "--quality works" in r.output and "--max-error" in r.output
    assert "max_error" not in r.output
    r = run("compress", tmp_path / "f.npy", tmp_path / "f.vpk", "--codec", "wavelet", ok=False)
    assert "--codec zstd" in r.output, r.output


def test_an_unexpected_exception_is_an_internal_error_with_exit_3(tmp_path, monkeypatch):
    import volpack.api

    def boom(*a, **k):
        raise KeyError("a bug")

    monkeypatch.setattr(volpack.api, "info", boom)
    np.save(tmp_path / "a.npy", np.zeros((2, 2, 2), np.uint8))
    r = CliRunner().invoke(main, ["info", str(tmp_path / "a.npy")])
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert r.exit_code == 3 and lines == [
        "volpack: internal error, please report: KeyError: 'a bug'"
    ]
    r = CliRunner().invoke(main, ["--debug", "info", str(tmp_path / "a.npy")])
    assert r.exit_code == 3 and "Traceback" in r.output and "boom" in r.output


def test_global_flags_may_follow_the_command(tmp_path):
    from volpack.cli import hoist_global_flags

    np.save(tmp_path / "a.npy", np.arange(4 * 5 * 6, dtype=np.int16).reshape(4, 5, 6))
    run("compress", tmp_path / "a.npy", tmp_path / "b.vpk", "-q", "--debug")
    run("-q", "compress", tmp_path / "a.npy", tmp_path / "c.vpk")
    assert (tmp_path / "b.vpk").read_bytes() == (tmp_path / "c.vpk").read_bytes()
    args = ["render", "a.npy", "o.png", "-vv", "--", "-q"]
    assert hoist_global_flags(args) == ["-vv", "render", "a.npy", "o.png", "--", "-q"]


def test_usage_errors_exit_2():
    r = run("compress", "--coder", "nonsense", "a", "b", ok=False)
    assert r.exit_code == 2


@pytest.mark.parametrize(
    "args, words",
    [
        (("--size", "0x10"), "1..16384 per side"),
        (("--size", "100000x100000"), "1..16384 per side"),
        (("--step", "1e-9"), "x>=0.01"),
        (("--iso", ","), "at least one isosurface"),
        (("--frame", "9"), "a frame in 0..1"),
    ],
)
def test_bad_view_options_are_usage_errors_naming_the_option(tmp_path, args, words):
    np.save(tmp_path / "v.npy", np.zeros((2, 4, 5, 6), np.float32))
    r = run("render", tmp_path / "v.npy", tmp_path / "o.png", *args, ok=False)
    assert r.exit_code == 2 and words in r.output and args[0] in r.output, r.output
    assert "internal error" not in r.output and not (tmp_path / "o.png").exists()


def test_convert_crop_downsample_quantize(tmp_path):
    a = smooth_volume((20, 30, 40), np.int16)
    np.save(tmp_path / "a.npy", a)
    run(
        "convert",
        tmp_path / "a.npy",
        tmp_path / "c.npy",
        "--crop",
        "2:18,0:30,10:40",
        "--downsample",
        "2",
    )
    c = np.load(tmp_path / "c.npy")
    assert c.shape == (8, 15, 15) and c.dtype == np.int16
    f = (np.random.default_rng(0).normal(size=(6, 7, 8)) * 10).astype(np.float32)
    np.save(tmp_path / "f.npy", f)
    d = json.loads(
        run("convert", tmp_path / "f.npy", tmp_path / "q.npy", "--quantize", "16", "--json").stdout
    )
    q = np.load(tmp_path / "q.npy")
    assert q.dtype == np.uint16
    meta = d["meta"]["quantize"]
    deq = q * meta["scale"] + meta["offset"]
    assert np.abs(deq - f).max() <= meta["max_error"] + 1e-9


@pytest.mark.slow
def test_stdin_to_hdf5_and_stdout(tmp_path):
    import io

    a = smooth_volume((5, 6, 7), np.uint8)
    buf = io.BytesIO()
    np.save(buf, a)
    run("convert", "-", f"{tmp_path / 'out.h5'}:/data", input=buf.getvalue())
    import h5py

    with h5py.File(tmp_path / "out.h5") as f:
        np.testing.assert_array_equal(f["data"][...], a)
    # compress to stdout, decompress from stdin: a pipeline
    np.save(tmp_path / "a.npy", a)
    vpk = subprocess.run(
        [sys.executable, "-m", "volpack", "compress", str(tmp_path / "a.npy"), "-"],
        capture_output=True,
        check=True,
    ).stdout
    npy = subprocess.run(
        [sys.executable, "-m", "volpack", "decompress", "-", "-"],
        input=vpk,
        capture_output=True,
        check=True,
    ).stdout
    np.testing.assert_array_equal(np.load(io.BytesIO(npy)), a)


@pytest.mark.slow
def test_demo_runs_and_checks_every_round_trip(tmp_path):
    r = run("demo", "--out", tmp_path / "demo", "--repeat", "1", "--json")
    d = json.loads(r.stdout)
    lossless = [row for row in d["rows"] if row["lossless"]]
    lossy = [row for row in d["rows"] if not row["lossless"]]
    assert len(lossless) >= 5 and len(lossy) >= 3
    assert all(row["psnr"] > 35 and row["ratio"] > row["psnr"] / 20 for row in lossy)
    assert max(row["ratio"] for row in lossless) > 2.0
    bounded = [row for row in lossy if "max error" in row["stage"]]
    assert bounded and all(row["max_error"] <= 2 for row in bounded)
    assert os.path.exists(d["input"])
    from PIL import Image

    with Image.open(d["preview"]["file"]) as im:  # the decoded MRI, rendered
        assert im.size[0] >= 256 and max(im.convert("L").getextrema()) > 50


def test_lossy_compress_info_and_decompress(tmp_path):
    a = smooth_volume((30, 40, 50), np.int16, seed=8, noise=4.0).astype(np.float32) / 3
    a[0, 0, :5] = np.nan
    src, vpk, back = tmp_path / "a.npy", tmp_path / "a.vpk", tmp_path / "b.npy"
    np.save(src, a)
    r = run("compress", src, vpk, "--max-error", "0.5", "--json")
    stats = json.loads(r.stdout)
    assert stats["lossless"] is False and stats["max_error"] <= 0.5 and stats["ratio"] > 1
    info = json.loads(run("info", vpk, "--json").stdout)
    assert info["summary"]["error_bound"] == 0.5 and info["summary"]["psnr"] > 40
    text = run("info", vpk).output
    assert "error bound" in text and "PSNR" in text
    run("decompress", vpk, back)
    b = np.load(back)
    ok = np.isfinite(a)
    assert np.abs(b[ok] - a[ok]).max() <= 0.5 and np.isnan(b[~ok]).all()
    r = run("compress", src, tmp_path / "q.vpk", "--quality", "63", ok=False)
    assert r.exit_code == 1 and "integer" in r.output  # quality is for integer volumes
    r = run("compress", src, tmp_path / "two.vpk", "--psnr", "40", "--ratio", "9", ok=False)
    assert r.exit_code == 1 and "at most one" in r.output


def test_float64_near_1e300_reports_what_it_knows(tmp_path):
    """Errors whose squares overflow float64: `info` and the compress line say the PSNR
    and RMSE of the stored summary are unknown (they used to crash `info` or print
    'PSNR inf'); `compare` of the decoded file computes them anyway."""
    a = np.random.default_rng(2).normal(0, 1, (8, 9, 10)) * 2.0**995
    src, vpk, back = tmp_path / "a.npy", tmp_path / "a.vpk", tmp_path / "b.npy"
    np.save(src, a)
    r = run("compress", src, vpk, "--rel-error", "1e-3")
    assert "PSNR unknown" in r.output and "PSNR inf" not in r.output
    text = run("info", vpk).output
    assert "PSNR         unknown" in text and "RMSE         unknown" in text
    run("decompress", vpk, back)
    got = json.loads(run("compare", src, back, "--json").stdout)
    assert np.isfinite(got["psnr"]) and 50 < got["psnr"] < 200
    assert 0 < got["rmse"] <= got["max_error"] <= 1e-3 * np.ptp(a)


def test_float64_near_1e_minus_300_reports_what_it_knows(tmp_path):
    """Errors whose squares underflow to 0: the summary says the PSNR and RMSE are
    unknown, not 'inf' and 0 (voxels do differ)."""
    a = np.random.default_rng(2).normal(0, 1, (8, 9, 10)) * 2.0**-995
    src, vpk = tmp_path / "a.npy", tmp_path / "a.vpk"
    np.save(src, a)
    r = run("compress", src, vpk, "--rel-error", "1e-3")
    assert "PSNR unknown (squared errors beyond float64's range)" in r.output
    text = run("info", vpk).output
    assert "PSNR         unknown" in text and "RMSE         unknown" in text
    assert "max error    0 " not in text


@pytest.mark.slow
def test_warmup_runs_every_kernel_path():
    r = CliRunner().invoke(main, ["warmup", "--json"])
    assert r.exit_code == 0, r.output
    rep = json.loads(r.stdout)
    assert rep["kernels"] > 0 and rep["paths"] == ["render", "animation", "octree", "mesh"]
    # what a user does first then compiles nothing more: the default coders and the
    # renderer on a CT-like int16 volume and a float field of other shapes than warm-up's
    from numba.core import event

    from volpack import api
    from volpack.render.camera import Camera
    from volpack.render.raycast import render
    from volpack.render.transfer import TransferFunction

    compiled = []

    class Listener(event.Listener):
        def on_start(self, ev):
            compiled.append(ev.data["dispatcher"].py_func.__name__)

        def on_end(self, ev):
            pass

    event.register("numba:compile", Listener())
    z, y, x = np.mgrid[:30, :70, :41]
    field = 800 * np.sin(x / 7 + y / 9) + 20 * z + np.random.default_rng(5).normal(0, 3, z.shape)
    for a in (field.astype(np.int16), (field / 100).astype(np.float32)):
        r = float(np.ptp(a))
        for opts in ({}, {"rel_error": 1e-3}, {"rel_error": 1e-3, "effort": "fast"}):
            api.decompress_array(api.compress_array(a, **opts))
        lo = float(np.median(a))
        points = ((lo, 0, 0, 0, 0), (lo + 0.3 * r, 1, 0.8, 0.6, 0.9), (float(a.max()), 1, 1, 1, 1))
        tf = TransferFunction(points)
        for shading in ("none", "phong"):
            render(a, tf=tf, camera=Camera(size=(64, 48)), shading=shading)
    assert compiled == [], f"compiled after warm-up: {sorted(set(compiled))}"


def test_convert_sets_spacing_and_origin_and_resample_has_its_own_name(tmp_path):
    a = smooth_volume((6, 8, 10), np.int16)
    np.save(tmp_path / "a.npy", a)
    out = tmp_path / "a.nii.gz"
    run("convert", tmp_path / "a.npy", out, "--spacing", "2,1,0.5", "--origin", "1,2,3")
    from volpack import io as vio

    vol = vio.read_volume(str(out))
    np.testing.assert_array_equal(vol.data, a)  # metadata only: the voxels are untouched
    assert vol.spacing == (2.0, 1.0, 0.5) and vol.origin == (1.0, 2.0, 3.0)
    run("convert", out, tmp_path / "iso.npy", "--resample", "1")
    assert np.load(tmp_path / "iso.npy").shape == (11, 8, 5)  # (n - 1) * spacing + 1 per axis
    r = run("convert", tmp_path / "a.npy", tmp_path / "b.npy", "--spacing", "1,0,1", ok=False)
    assert r.exit_code == 2 and "expected three positive numbers Z,Y,X" in r.output


def test_raw_shape_is_echoed_in_z_y_x_order(tmp_path):
    a = smooth_volume((3, 5, 7), np.int16)
    (tmp_path / "grads.dat").write_bytes(a.tobytes())
    r = run(
        "convert",
        tmp_path / "grads.dat",
        tmp_path / "g.npy",
        "--shape",
        "3,5,7",
        "--dtype",
        "int16",
    )
    assert "raw input of shape (z, y, x) = (3, 5, 7), x fastest, int16" in r.stderr
    np.testing.assert_array_equal(np.load(tmp_path / "g.npy"), a)
    assert "zfp" in run("convert", "--help").output  # the help says which way round


def test_info_over_many_files_is_one_table_and_ratios_agree(tmp_path):
    a = smooth_volume((12, 14, 16), np.int16)
    np.save(tmp_path / "a.npy", a)
    r = run("compress", tmp_path / "a.npy", tmp_path / "a.vpk")
    printed = float(r.stderr.split("ratio ")[1].split(":")[0])
    d = json.loads(run("info", tmp_path / "a.vpk", "--json").stdout)
    assert printed == pytest.approx(d["ratio"], abs=5e-4)  # compress and info agree
    assert f"{os.path.getsize(tmp_path / 'a.vpk') / 1000:.2f} kB" in r.stderr
    assert "int16" in run("info", tmp_path / "a.vpk").output  # numpy's name, not '<i2'
    (tmp_path / "b.nii").write_bytes(b"not a nifti")
    r = run("info", tmp_path / "a.npy", tmp_path / "a.vpk", tmp_path / "b.nii", ok=False)
    assert r.exit_code == 1
    lines = r.output.splitlines()
    assert lines[0].split()[:4] == ["file", "format", "shape", "(z,y,x)"]
    assert "12x14x16" in lines[2] and "int16" in lines[2] and "npy" in lines[2]
    assert "vpk/volume" in lines[3] and f"{d['ratio']:.3f}" in lines[3]
    assert "error" in lines[4] and "b.nii: could not read nifti" in r.output
    rows = json.loads(run("info", tmp_path / "a.npy", tmp_path / "a.vpk", "--json").stdout)
    assert [row["format"] for row in rows] == ["npy", "vpk/volume"]


def test_compare_reports_what_a_compress_and_decompress_measure(tmp_path):
    a = smooth_volume((20, 24, 28), np.int16, noise=8.0)
    np.save(tmp_path / "a.npy", a)
    r = json.loads(run("compare", tmp_path / "a.npy", "--max-error", "3", "--json").stdout)
    run("compress", tmp_path / "a.npy", tmp_path / "a.vpk", "--max-error", "3")
    assert r["file_nbytes"] == os.path.getsize(tmp_path / "a.vpk")  # same bytes as a file
    run("decompress", tmp_path / "a.vpk", tmp_path / "b.npy")
    b = np.load(tmp_path / "b.npy").astype(np.int64)
    err = np.abs(b - a).max()
    assert r["max_error"] == err <= 3 and not r["lossless"]
    mse = ((b - a) ** 2).mean()
    assert r["psnr"] == pytest.approx(10 * np.log10(float(a.max() - a.min()) ** 2 / mse))
    assert r["ratio"] == pytest.approx(a.nbytes / r["file_nbytes"])
    assert r["enc_mb_s"] > 0 and r["dec_mb_s"] > 0
    text = run("compare", tmp_path / "a.npy").output
    assert "0 (lossless)" in text and "ratio" in text and "decode" in text


def test_compare_measures_float_errors_over_the_finite_voxels(tmp_path):
    a = (smooth_volume((20, 24, 28), np.int16, noise=8.0) / 7.0).astype(np.float32)
    a[2, 3, 4], a[5, 6, 7] = np.nan, np.inf
    np.save(tmp_path / "a.npy", a)
    r = json.loads(run("compare", tmp_path / "a.npy", "--max-error", "0.5", "--json").stdout)
    run("compress", tmp_path / "a.npy", tmp_path / "a.vpk", "--max-error", "0.5")
    run("decompress", tmp_path / "a.vpk", tmp_path / "b.npy")
    b = np.load(tmp_path / "b.npy").astype(np.float64)
    ok = np.isfinite(a)
    d = b[ok] - a[ok].astype(np.float64)
    assert 0 < r["max_error"] == pytest.approx(np.abs(d).max()) and r["max_error"] <= 0.5
    peak = float(a[ok].max() - a[ok].min())
    assert r["psnr"] == pytest.approx(10 * np.log10(peak**2 / (d**2).mean()))
    assert not r["lossless"]


def test_compare_leaves_the_fill_value_out_of_its_errors_and_psnr(tmp_path):
    """Session 37 (psnr37): with --fill-value, compare reported the PSNR with the fill
    (1e35) as its peak, 700 dB, where the encoder's own search had reached its target
    over the other voxels; the fill voxels now leave the measure (as NaN does) and must
    come back bit for bit."""
    a = (smooth_volume((12, 20, 24), np.int16, noise=8.0) / 7.0).astype(np.float32)
    a[:3, :5] = 1e35
    np.save(tmp_path / "a.npy", a)
    args = ("--fill-value", "1e35", "--json")
    r = json.loads(run("compare", tmp_path / "a.npy", "--max-error", "0.5", *args).stdout)
    run("compress", tmp_path / "a.npy", tmp_path / "a.vpk", "--max-error", "0.5", "--fill-value", "1e35")
    run("decompress", tmp_path / "a.vpk", tmp_path / "b.npy")
    b = np.load(tmp_path / "b.npy")
    ok = a != np.float32(1e35)
    assert np.array_equal(b[~ok], a[~ok])
    d = b[ok].astype(np.float64) - a[ok]
    assert 0 < r["max_error"] <= 0.5 and r["max_error"] == pytest.approx(np.abs(d).max())
    peak = float(a[ok].max() - a[ok].min())
    assert r["psnr"] == pytest.approx(10 * np.log10(peak**2 / (d**2).mean()))
    assert r["rmse"] == pytest.approx(np.sqrt((d**2).mean()))


@pytest.mark.slow
def test_compare_at_a_psnr_target_with_a_fill_value_reports_the_psnr_reached(tmp_path):
    """The same (psnr37) under --psnr: compare's PSNR is the one the search reached."""
    a = (smooth_volume((12, 20, 24), np.int16, noise=8.0) / 7.0).astype(np.float32)
    a[:3, :5] = 1e35
    np.save(tmp_path / "a.npy", a)
    r = run("compare", tmp_path / "a.npy", "--psnr", "40", "--fill-value", "1e35", "--json")
    r = json.loads(r.stdout)
    assert r["psnr"] == pytest.approx(r["compress"]["psnr"]) and abs(r["psnr"] - 40) < 0.5


def test_compare_measures_a_second_volume_against_the_first(tmp_path):
    a = (smooth_volume((6, 7, 8), np.int16, noise=8.0) / 7.0).astype(np.float32)
    a[1, 2, 3], a[2, 3, 4] = np.nan, np.inf
    b = a.copy()
    b[0, 0, :3] += np.float32([0.5, -0.25, 0.0])
    a[3, 3, 3] = 0.0
    b[3, 3, 3] = -0.0  # equal values, other bits: differs, no error
    np.save(tmp_path / "a.npy", a)
    np.save(tmp_path / "b.npy", b)
    r = json.loads(run("compare", tmp_path / "a.npy", tmp_path / "b.npy", "--json").stdout)
    ok = np.isfinite(a)
    d = b[ok].astype(np.float64) - a[ok]
    assert r["max_error"] == 0.5 and r["differing"] == 3 and not r["identical"]
    peak = float(a[ok].max() - a[ok].min())
    assert r["psnr"] == pytest.approx(10 * np.log10(peak**2 / (d**2).mean()))
    assert r["rmse"] == pytest.approx(np.sqrt((d**2).mean()))
    # a .vpk reads as the volume it holds; a file against its own coding is identical
    run("compress", tmp_path / "a.npy", tmp_path / "a.vpk")
    text = run("compare", tmp_path / "a.npy", tmp_path / "a.vpk").output
    assert "identical (bit for bit)" in text
    b[1, 2, 3] = 1.0  # a NaN lost is an infinite error
    np.save(tmp_path / "b.npy", b)
    r = json.loads(run("compare", tmp_path / "a.npy", tmp_path / "b.npy", "--json").stdout)
    assert r["max_error"] is None or r["max_error"] == float("inf")
    np.save(tmp_path / "c.npy", a[:3])
    r = run("compare", tmp_path / "a.npy", tmp_path / "c.npy", ok=False)
    assert r.exit_code == 1 and "same shape, found 6x7x8 and 3x7x8" in r.stderr
    r = run("compare", tmp_path / "a.npy", tmp_path / "b.npy", "--max-error", "1", ok=False)
    assert r.exit_code == 1 and "found --max-error with a second volume" in r.stderr


def test_compare_with_peers_runs_them_on_the_same_voxels(tmp_path):
    a = smooth_volume((6, 20, 24), np.int16, noise=8.0)
    np.save(tmp_path / "a.npy", a)
    src = tmp_path / "a.npy"
    r = json.loads(run("compare", src, "--peers", "--jpegxl-efforts", "1", "--json").stdout)
    assert r["peers_bound"] is None and r["lossless"]
    assert r["dec_mb_s_warm"] > 0 and r["dec_seconds_warm"] > 0  # decoded again, kernels loaded
    zstd = next(p for p in r["peers"] if p["name"] == "zstd-19+shuffle")
    assert zstd["lossless"] and zstd["ratio"] == pytest.approx(a.nbytes / zstd["file_nbytes"])
    text = run("compare", src, "--peers", "--jpegxl-efforts", "1").output
    assert "peers, losslessly" in text and "zstd-19+shuffle" in text and "exact" in text
    assert "(kernels loaded)" in text
    if importlib.util.find_spec("pysz") is not None:  # a bound: the same absolute one for all
        # (of at least 1: under it integer voxels are coded exactly)
        r = json.loads(run("compare", src, "--rel-error", "1e-2", "--peers", "--json").stdout)
        assert r["peers_bound"] == r["compress"]["error_bound"] > 0
        sz3 = next(p for p in r["peers"] if p["name"] == "sz3")
        assert sz3["bound_held"] and sz3["max_error"] <= r["peers_bound"]
    for args, message in [
        (("--psnr", "40"), "--peers compares losslessly or at one error bound"),
        ((src,), "does not apply with a second volume"),
        (("--jpegxl-efforts", "11"), "expected efforts 1-10"),
    ]:
        r = run("compare", src, "--peers", *args, ok=False)
        assert r.exit_code == 2 and message in r.output


def test_messages_name_flags_only(tmp_path):
    np.save(tmp_path / "a.npy", smooth_volume((6, 7, 8)))
    run("compress", tmp_path / "a.npy", tmp_path / "a.vpk")
    r = run("compress", tmp_path / "a.npy", tmp_path / "a.vpk", ok=False)
    assert r.exit_code == 1 and "pass --force to replace it" in r.stderr and "=True" not in r.stderr
    r = run("compress", tmp_path / "a.npy", tmp_path / "b.vpk", "--max-error", "2", "--psnr", "45",
            ok=False)  # fmt: skip
    assert "found --max-error 2.0, --psnr 45.0" in r.stderr and "[" not in r.stderr
    (tmp_path / "r.bin").write_bytes(bytes(1000))
    r = run("info", tmp_path / "r.bin", "--shape", "10,10,10", ok=False)
    assert "expected --dtype for raw input" in r.stderr and "dtype=" not in r.stderr
    r = run("info", tmp_path / "r.bin", "--dtype", "uint8", ok=False)
    assert "expected --shape Z,Y,X" in r.stderr and "shape=" not in r.stderr
    r = run("compress", tmp_path / "a.npy", tmp_path / "c.vpk", "--offset", "4", ok=False)
    assert "expected --shape and --dtype with an offset" in r.stderr and "offset=" not in r.stderr
