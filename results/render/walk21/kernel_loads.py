"""Wall time spent inside the kernel cache's loads during a ``walk --orbit 1 -j 1`` run in
this process (with one worker every load is on the main thread, one after another).
Run with PYTHONPATH=<tree>; the argument is a label for the output line:

    PYTHONPATH=/work/main python results/render/walk21/kernel_loads.py main
"""

import contextlib
import io
import sys
import tempfile
import time

label = sys.argv[1]
sys.argv = ["volpack", "-q", "walk", "/work/lead/walk/o.vpk", tempfile.mkdtemp() + "/",
            "--orbit", "1", "--json", "-j", "1", "--force"]  # fmt: skip
import volpack._jit as jit  # noqa: E402

cache = jit._KERNEL_CACHE
load = cache.load_overload
times = []


def timed_load(self, sig, ctx):
    t = time.perf_counter()
    try:
        return load(self, sig, ctx)
    finally:
        times.append(time.perf_counter() - t)


cache.load_overload = timed_load
from volpack.cli import main  # noqa: E402

with contextlib.redirect_stdout(io.StringIO()):
    try:
        main(standalone_mode=False)
    except SystemExit:
        pass
print(f"{label} {len(times)} loads, all {1000 * sum(times):.1f} ms, "
      f"after the first {1000 * sum(times[1:]):.1f} ms")  # fmt: skip
