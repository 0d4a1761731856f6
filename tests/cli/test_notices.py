"""The first-run notice and the periodic lines a command prints when stderr is no terminal."""

from __future__ import annotations

import io
import time

from volpack import jitwatch
from volpack.cli.notices import Notices


def _wait_for(pred, timeout=10.0):
    t = time.monotonic()
    while not pred() and time.monotonic() - t < timeout:
        time.sleep(0.01)
    return pred()


def test_first_compile_notice_once_then_lines(monkeypatch):
    monkeypatch.setattr(jitwatch, "fresh_cache", True)
    monkeypatch.setattr(jitwatch, "cache_dir", "/cache/jit/abc")
    out = io.StringIO()
    n = Notices(out, interval=0.05)
    try:
        n.on_compile("start", "_dwt3_kernel", None)
        n.on_compile("start", "_lift_kernel", None)  # nested: no second notice
        assert _wait_for(lambda: "compiling kernels (0 compiled so far)" in out.getvalue())
        n.on_compile("end", "_lift_kernel", 0.5)
        n.on_compile("end", "_dwt3_kernel", 1.0)
        progress = n.task("compress", "brick")
        progress(3, 8)
        assert _wait_for(lambda: "compress 3/8 bricks" in out.getvalue())
    finally:
        n.close()
    text = out.getvalue()
    assert text.count("first run") == 1
    first = text.splitlines()[0]
    assert "_dwt3_kernel" in first and "/cache/jit/abc" in first and "volpack warmup" in first


def test_no_notice_on_a_warm_cache_and_nothing_when_quiet(monkeypatch):
    monkeypatch.setattr(jitwatch, "fresh_cache", False)
    out = io.StringIO()
    n = Notices(out, interval=0.05)
    n.on_compile("start", "k", None)  # a new type signature compiles on a warm cache too
    assert _wait_for(lambda: "compiling kernels" in out.getvalue())
    n.on_compile("end", "k", 0.1)
    n.close()
    assert "first run" not in out.getvalue()
    monkeypatch.setattr(jitwatch, "fresh_cache", True)
    quiet = io.StringIO()
    q = Notices(quiet, quiet=True, interval=0.01)
    q.on_compile("start", "k", None)
    q.task("demo", "stage")(1, 9)
    time.sleep(0.1)
    q.close()
    assert quiet.getvalue() == ""


def test_a_command_that_ends_quickly_prints_nothing():
    out = io.StringIO()
    n = Notices(out, interval=5.0)
    n.task("decompress", "brick")(1, 1)
    n.close()
    assert out.getvalue() == ""


def test_a_task_of_unknown_length_counts_without_a_total():
    # `volpack play -` learns the frame count only as it plays (it was an internal error)
    out = io.StringIO()
    n = Notices(out, interval=0.05)
    try:
        n.task("play", "frame")(3, None)
        assert _wait_for(lambda: "play 3 frames" in out.getvalue())
    finally:
        n.close()
    assert "/" not in out.getvalue().split("play 3")[1].splitlines()[0]
