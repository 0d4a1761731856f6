"""pytest plugin: CPU seconds per test, and how many of them went to compiling kernels.

On a machine shared with other jobs wall-clock durations measure the neighbours; CPU
time does not. Used to choose the tests marked ``slow``:

    PYTHONPATH=scripts pytest -p pytest_cputime -n 2 -p no:cacheprovider    # -> results/test_cpu.csv

Each xdist worker appends its rows to ``$VOLPACK_TEST_CPU`` (default
``results/test_cpu.csv``): nodeid, cpu seconds (setup, call and teardown, child processes
included), of which compiling (in this process). A test's own cost is the difference; the compile share lands on whichever test
first used a kernel.

With ``$VOLPACK_TEST_KERNELS`` set to a path, each worker also appends a row per compiled
kernel signature: kernel, argument types, the test that first asked for it, and the CPU
seconds of that compile without its callees' (how the read-only duplicates of the
renderer's kernels were found: a file read by the CLI is read-only, an API array not).
"""

from __future__ import annotations

import os
import resource
import time

import pytest

_compile = [0.0]
_depth = [0]


def _on_compile(event, name, seconds):
    # count the outermost compilation only: callees compile inside their callers
    _depth[0] += 1 if event == "start" else -1
    if event == "end" and _depth[0] == 0:
        _compile[0] += seconds or 0.0


_current = ["?"]


def _watch_signatures(path: str) -> None:
    from numba.core import event

    stack = []  # [start CPU, CPU of nested compiles, row]

    class _Kernels(event.Listener):
        def on_start(self, ev):
            fn = getattr(ev.data.get("dispatcher"), "py_func", None)
            name = f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', '?')}"
            args = " ".join(str(ev.data.get("args")).split()).replace('"', "'")
            stack.append([time.thread_time(), 0.0, (name, args, _current[0])])

        def on_end(self, ev):
            t0, nested, (name, args, test) = stack.pop()
            dt = time.thread_time() - t0
            if stack:
                stack[-1][1] += dt
            with open(path, "a") as f:
                f.write(f'"{name}","{args}","{test}",{dt - nested:.3f}\n')

    event.register("numba:compile", _Kernels())


def pytest_configure(config):
    from volpack import jitwatch

    jitwatch.subscribe(_on_compile)
    if os.environ.get("VOLPACK_TEST_KERNELS"):
        _watch_signatures(os.environ["VOLPACK_TEST_KERNELS"])


def pytest_runtest_setup(item):
    _current[0] = item.nodeid


def _children() -> float:
    """CPU seconds of finished child processes (CLI runs in a subprocess, dask workers)."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    c0, k0, s0 = time.process_time(), _compile[0], _children()
    yield
    cpu, comp = time.process_time() - c0 + _children() - s0, _compile[0] - k0
    path = os.environ.get("VOLPACK_TEST_CPU", "results/test_cpu.csv")
    with open(path, "a") as f:
        f.write(f'"{item.nodeid}",{cpu:.3f},{comp:.3f}\n')
