"""``volpack serve``: commands forwarded to a resident process give what a process of
their own gives (output, exit code, bytes written); everything else runs locally."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import smooth_volume

from volpack import serve as sv
from volpack.cli import main
from volpack.cli.serve import _runner
from volpack.errors import OptionError


@pytest.fixture
def server(tmp_path, monkeypatch):
    """A server of this install in a thread, on a private socket folder; yields its path.
    It never idles out: a test may compile kernels for minutes before its first request."""
    d = tmp_path / "sock"
    d.mkdir(mode=0o700)
    monkeypatch.setenv("VOLPACK_SERVE_DIR", str(d))
    monkeypatch.delenv("VOLPACK_SERVE", raising=False)
    path = sv.socket_path()
    up = threading.Event()
    done: list[int] = []
    t = threading.Thread(
        target=lambda: done.append(sv.serve(_runner, path, idle=0, warm=False, ready=up.set)),
        daemon=True,
    )
    t.start()
    assert up.wait(30)
    yield path
    if t.is_alive():
        assert sv.stop(path)
    t.join(30)
    assert not t.is_alive() and not path.exists()  # the socket goes with the server


def local(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.mark.parametrize(
    "argv, command",
    [
        (["render", "a.npy", "b.png"], "render"),
        (["-q", "--debug", "info", "a.npy"], "info"),
        (["info", "-", "--json"], None),  # standard input
        (["render", "a.npy", "b.png", "--help"], None),
        (["--version"], None),
        (["compress", "a.npy", "a.vpk"], None),
        (["walk", "o.vpk", "out/", "--orbit", "3"], "walk"),
        (["serve", "--stop"], None),
        ([], None),
    ],
)
def test_which_commands_a_server_may_run(argv, command):
    assert sv.served_command(argv) == command


# slow set: 2-4 CPU s of its own (session 34: the fast set reached its 6 minutes)
@pytest.mark.slow
def test_info_served_as_run_locally(server, tmp_path, capfd, monkeypatch):
    src = tmp_path / "a.npy"
    np.save(src, np.arange(60, dtype=np.int16).reshape(3, 4, 5))
    want = local("info", src, "--json")
    assert sv.forward(["info", str(src), "--json"]) == 0
    got = capfd.readouterr().out
    assert json.loads(got) == json.loads(want.stdout)
    # a relative path is the client's: the server works in the client's folder
    monkeypatch.chdir(tmp_path)
    assert sv.forward(["info", "a.npy"]) == 0
    assert "3 x 4 x 5" in capfd.readouterr().out
    # errors keep their exit code and their one line
    assert sv.forward(["info", str(tmp_path / "missing.npy")]) == 1
    err = capfd.readouterr().err
    assert err.startswith("volpack: error:") and "missing.npy" in err
    assert sv.forward(["info", str(src), "--no-such-flag"]) == 2


# slow set: 2-4 CPU s of its own (session 34: the fast set reached its 6 minutes)
@pytest.mark.slow
def test_render_served_writes_the_same_bytes(server, tmp_path):
    src = tmp_path / "ball.npy"
    np.save(src, smooth_volume((24, 24, 24), np.uint8))  # uint8, as test_render's CLI case
    assert local("render", src, tmp_path / "local.png", "--size", "40x30").exit_code == 0
    assert (
        sv.forward(["-q", "render", str(src), str(tmp_path / "served.png"), "--size", "40x30"]) == 0
    )
    assert (tmp_path / "served.png").read_bytes() == (tmp_path / "local.png").read_bytes()
    # the client's umask, not the server's (this process keeps its own)
    with socket.socket(socket.AF_UNIX) as s:
        s.connect(str(server))
        argv = ["render", str(src), str(tmp_path / "private.png"), "--size", "8x8"]
        sv._send(s, {"v": sv.PROTOCOL, "argv": argv, "cwd": str(tmp_path), "stamp": sv.stamp(),
                     "umask": 0o077})  # fmt: skip
        *said, last = sv._messages(s)  # what it printed on stderr first, then its code
        assert last["code"] == 0 and said and all("err" in m for m in said)
    assert (tmp_path / "private.png").stat().st_mode & 0o777 == 0o600
    mask = os.umask(0o022)
    os.umask(mask)
    assert mask != 0o077  # put back after the request
    # refused without --force, as locally, and the file is untouched
    assert sv.forward(["render", str(src), str(tmp_path / "served.png"), "--size", "40x30"]) == 1
    assert (tmp_path / "served.png").read_bytes() == (tmp_path / "local.png").read_bytes()


# slow set: 2-4 CPU s of its own (session 34: the fast set reached its 6 minutes)
@pytest.mark.slow
def test_what_runs_locally(server, tmp_path, monkeypatch):
    src = tmp_path / "a.npy"
    np.save(src, np.zeros((2, 2, 2), np.uint8))
    assert sv.forward(["info", str(src)]) == 0
    assert sv.forward(["compress", str(src), str(tmp_path / "a.vpk")]) is None
    monkeypatch.setenv("VOLPACK_SERVE", "0")
    assert sv.forward(["info", str(src)]) is None
    monkeypatch.delenv("VOLPACK_SERVE")
    # other settings: another stamp, so another socket, where nothing listens
    monkeypatch.setenv("VOLPACK_THREADS", "1")
    assert sv.forward(["info", str(src)]) is None
    monkeypatch.delenv("VOLPACK_THREADS")
    assert sv.forward(["info", str(src)]) == 0


def test_a_request_with_another_stamp_is_refused(server, tmp_path):
    with socket.socket(socket.AF_UNIX) as s:
        s.connect(str(server))
        sv._send(s, {"v": sv.PROTOCOL, "argv": ["info", "x"], "cwd": str(tmp_path),
                     "stamp": "0" * 16})  # fmt: skip
        reply = sv._receive(s)
    assert reply["code"] is None and "stale" in reply["error"]


@pytest.mark.parametrize(
    "raw",
    [b"not json\n", b"[1, 2]\n", b'{"v": 99}\n', b'{"v": 1, "argv": "info"}\n',
     b'{"v": 1, "argv": ["compress", "a", "b"], "cwd": "/"}\n', b'{"v": 1, "argv": ["info"]}\n',
     b"", b"{" + b" " * 1000],  # closed early; cut short
)  # fmt: skip
def test_bad_requests_leave_the_server_serving(server, tmp_path, raw):
    with socket.socket(socket.AF_UNIX) as s:
        s.connect(str(server))
        s.sendall(raw)
        s.shutdown(socket.SHUT_WR)
        reply = sv._receive(s)
    assert reply is None or reply.get("code") is None
    src = tmp_path / "a.npy"
    np.save(src, np.zeros((2, 2, 2), np.uint8))
    assert sv.forward(["info", str(src)]) == 0


def test_a_folder_others_can_enter_is_refused(tmp_path, monkeypatch):
    d = tmp_path / "open"
    d.mkdir(mode=0o755)
    os.chmod(d, 0o755)
    monkeypatch.setenv("VOLPACK_SERVE_DIR", str(d))
    with pytest.raises(OptionError, match="0700"):
        sv.serve(_runner, sv.socket_path(), warm=False, idle=1)
    assert sv.forward(["info", "a.npy"]) is None


def test_a_second_server_is_refused_and_a_stale_socket_replaced(server, tmp_path):
    with pytest.raises(OptionError, match="already listens"):
        sv.serve(_runner, server, warm=False, idle=1)
    stale = server.parent / "stale.sock"
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(stale))  # bound, never listening: what a killed server leaves
    assert sv.serve(_runner, stale, warm=False, idle=0.2) == 0  # idles out
    assert not stale.exists()


@pytest.mark.slow  # two processes; the detached one warms the render kernels
def test_the_volpack_command_through_a_detached_server(tmp_path):
    d = tmp_path / "sock"
    d.mkdir(mode=0o700)
    env = dict(os.environ, VOLPACK_SERVE_DIR=str(d))
    env.pop("VOLPACK_SERVE", None)
    exe = [sys.executable, "-c", "from volpack.launch import run; run()"]
    up = subprocess.run([*exe, "serve", "--detach", "--no-warm", "--idle", "120", "--json"],
                        env=env, capture_output=True, text=True, check=True)  # fmt: skip
    pid = json.loads(up.stdout)["pid"]
    try:
        src = tmp_path / "a.npy"
        np.save(src, np.arange(24, dtype=np.uint8).reshape(2, 3, 4))
        got = subprocess.run([*exe, "info", str(src)], env=env, capture_output=True, text=True)
        want = subprocess.run([*exe, "info", str(src)], env=dict(env, VOLPACK_SERVE="0"),
                              capture_output=True, text=True)  # fmt: skip
        assert (got.returncode, got.stdout) == (want.returncode, want.stdout) == (0, want.stdout)
        status = subprocess.run([*exe, "serve", "--status", "--json"], env=env,
                                capture_output=True, text=True, check=True)  # fmt: skip
        assert json.loads(status.stdout)["listening"]
        again = subprocess.run([*exe, "serve", "--detach", "--no-warm", "--json"], env=env,
                               capture_output=True, text=True, check=True)  # fmt: skip
        assert json.loads(again.stdout)["pid"] is None  # the one listening is kept
    finally:
        subprocess.run([*exe, "serve", "--stop"], env=env, check=True, capture_output=True)
    status = subprocess.run([*exe, "serve", "--status", "--json"], env=env,
                            capture_output=True, text=True)  # fmt: skip
    assert status.returncode == 1 and not json.loads(status.stdout)["listening"]
    # `kill` ends a server as --stop does: its socket removed
    up = subprocess.run([*exe, "serve", "--detach", "--no-warm", "--idle", "120", "--json"],
                        env=env, capture_output=True, text=True, check=True)  # fmt: skip
    pid = json.loads(up.stdout)["pid"]
    sock = json.loads(up.stdout)["socket"]
    os.kill(pid, signal.SIGTERM)
    for _ in range(200):
        if not os.path.exists(sock):
            break
        time.sleep(0.05)
    assert not os.path.exists(sock)


def test_detach_says_when_the_server_ends_at_once(tmp_path):
    d = tmp_path / "open"
    d.mkdir(mode=0o755)
    os.chmod(d, 0o755)  # refused by the server: the parent must not wait for it
    env = dict(os.environ, VOLPACK_SERVE_DIR=str(d))
    out = subprocess.run(
        [sys.executable, "-m", "volpack", "serve", "--detach", "--no-warm"],
        env=env, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert out.returncode == 1 and "ended at once" in out.stderr


@pytest.mark.slow  # a walk's kernels
def test_walk_served_writes_a_local_walks_frames_and_times_the_clients_wait(server, tmp_path):
    from volpack.demo import load_demo_volume
    from volpack.octree import build

    path = tmp_path / "brain.vpk"
    build(load_demo_volume().data[10:42, 20:60, 16:64], str(path), block=8)

    def args(out):
        return ["walk", str(path), f"{out}/", "--orbit", "2", "--size", "32x32", "--json"]

    r = local(*args(tmp_path / "own"))
    assert r.exit_code == 0, r.output
    with socket.socket(socket.AF_UNIX) as s:
        s.connect(str(server))
        t0 = time.clock_gettime(time.CLOCK_BOOTTIME)  # "the client started now"
        sv._send(s, {"v": sv.PROTOCOL, "argv": args(tmp_path / "served"), "cwd": str(tmp_path),
                     "stamp": sv.stamp(), "started": t0})  # fmt: skip
        *_, last = sv._messages(s)
        waited = time.clock_gettime(time.CLOCK_BOOTTIME) - t0
    assert last["code"] == 0
    frames = sorted(os.listdir(tmp_path / "own"))
    assert frames == sorted(os.listdir(tmp_path / "served")) and len(frames) == 2
    for f in frames:
        assert (tmp_path / "own" / f).read_bytes() == (tmp_path / "served" / f).read_bytes()
    done = [f["finished_at"] for f in json.loads(last["out"])["per_frame"]]
    assert 0 <= done[0] <= done[-1] <= waited  # since the client's start, not the server's


def test_a_busy_server_still_counts_as_listening(server):
    # a client that connected and sends nothing keeps the server in its request (30 s):
    # it is busy, not gone, so no second server may take its socket
    with socket.socket(socket.AF_UNIX) as s:
        s.connect(str(server))
        assert sv.listening(server)
        with pytest.raises(OptionError, match="already listens"):
            sv.serve(_runner, server, warm=False, idle=1)
    assert server.exists()
