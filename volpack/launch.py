"""The ``volpack`` console entry: a server of this install runs the command if one is
listening (:mod:`volpack.serve`), else this process does (:func:`volpack.cli.run`).

Kept apart from :mod:`volpack.cli` so that a forwarded command imports neither click
nor numpy: the client's whole cost is the interpreter and a socket round trip.
"""

from __future__ import annotations

import contextlib
import gc
import os
import sys


#: OpenBLAS's idle threads poll for work for 2^28 cycles (its THREAD_TIMEOUT, about 0.1 s)
#: before they sleep, and numpy's import starts them: 0.11 s of a core burnt at the start
#: of every command, with no BLAS work to wait for (volpack's own workers do the heavy
#: lifting; the encoders hold BLAS to one thread, parallel.one_blas_thread). 2^4 cycles
#: make them sleep at once; a product large enough to use them still does.
BLAS_IDLE = ("OPENBLAS_THREAD_TIMEOUT", "4")


def run() -> None:
    os.environ.setdefault(*BLAS_IDLE)  # read when numpy loads OpenBLAS: before any import
    with _collector_paused():  # imports make objects, not garbage (cli.options.imports_without_gc)
        from . import serve
    code = serve.forward(sys.argv[1:])
    if code is not None:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):  # a closed pipe (volpack info | head)
                code = code or 1
        os._exit(code)  # as volpack.cli.run: nothing left to tear down or flush again
    with _collector_paused():
        from .cli import run as run_here
    run_here()


@contextlib.contextmanager
def _collector_paused():
    """The cycle collector paused, and what was made meanwhile frozen: ``run`` is a
    process's console entry, so nothing made here is ever garbage to collect."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        gc.freeze()
        if enabled:
            gc.enable()
