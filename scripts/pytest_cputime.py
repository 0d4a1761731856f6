"""pytest plugin: CPU seconds per test, and how many of them went to compiling kernels.

On a machine shared with other jobs wall-clock durations measure the neighbours; CPU
time does not. Used to choose the tests marked ``slow``:

    PYTHONPATH=scripts pytest -p pytest_cputime -n 2 -p no:cacheprovider    # -> results/test_cpu.csv

Each xdist worker appends its rows to ``$VOLPACK_TEST_CPU`` (default
``results/test_cpu.csv``): nodeid, cpu seconds (setup, call and teardown, child processes
included), of which compiling (in this process). A test's own cost is the difference; the compile share lands on whichever test
first used a kernel.
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


def pytest_configure(config):
    from volpack import jitwatch

    jitwatch.subscribe(_on_compile)


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
