"""The two brick tests of a walk's first frame, old against new, on the octrees' arrays:
brick ranges (``_brick_range_kernel`` against ``_int_brick_range_kernel``) and the
empty-brick test of the TF's tables (main's numpy ``_invisibility`` against
``_invisible_kernel``), least CPU of 5 calls each, one thread, and whether they agree.

    PYTHONPATH=<walk18 tree> python kernels.py MRI.npy CT.npy
"""

import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from volpack.render import raycast as rc
from volpack.render.transfer import TransferFunction

ROOT = Path(rc.__file__).resolve().parents[2]


def least(fn, *a):
    fn(*a)
    ts = []
    for _ in range(5):
        t = time.process_time()
        fn(*a)
        ts.append(time.process_time() - t)
    return 1000 * min(ts)


def main(paths):
    src = subprocess.run(["git", "-C", str(ROOT), "show", "a376e04:volpack/render/raycast.py"],
                         capture_output=True, text=True, check=True).stdout  # fmt: skip
    i = src.index("def _invisibility(")
    ns = {"np": np}
    exec(src[i : src.index("    return test\n", i) + len("    return test\n")], ns)
    old_inv = ns["_invisibility"]
    for p in paths:
        v = np.load(p)
        b = rc.brick_size(v.shape)
        nb = tuple(-(-n // b) for n in v.shape)
        out = {}
        for fn in (rc._brick_range_kernel, rc._int_brick_range_kernel):
            mins, maxs = np.empty(nb, np.float32), np.empty(nb, np.float32)
            ms = least(fn, rc.read_only(v), b, 0, nb[0], mins, maxs)
            out[fn.__name__] = (mins, maxs)
            print(f"{Path(p).stem} {v.dtype} {v.shape} bricks {nb}: {fn.__name__} {ms:.1f} ms")
        (a0, a1), (c0, c1) = out.values()
        print(f"  ranges equal: {np.array_equal(a0, c0) and np.array_equal(a1, c1)}")
        lo, hi = float(v.min()), float(v.max())
        n = 256
        scale = (n - 1) / (hi - lo)
        tf = TransferFunction(points=((lo + 0.1 * (hi - lo), 0.2, 0.9, 0.2, 0.0),
                                      (lo + 0.3 * (hi - lo), 0.2, 0.9, 0.2, 0.05),
                                      (lo + 0.45 * (hi - lo), 0, 0, 0, 0.0)))  # fmt: skip
        base = rc.transfer_table(tf, lo, hi, n)
        tabs = rc._frame_tables(base, 0.5, True, False, "fast")
        iso = np.zeros((1, 1, 4), np.float32)
        for mode, name in ((0, "post"), (2, "preintegrated")):
            res = []
            for f in (old_inv, rc._invisibility):
                t = f(mode, True, tabs.post, tabs.pre2d, iso, False, lo, scale)
                ms = least(t, a0, a1)
                res.append(t(a0, a1))
                print(f"  empty-brick test, {name}: {'numpy (main)' if f is old_inv else '_invisible_kernel'}"
                      f" {ms:.1f} ms, {int(res[-1].sum())} of {res[-1].size} bricks invisible")  # fmt: skip
            print(f"  same bricks: {np.array_equal(*res)}")


if __name__ == "__main__":
    main(sys.argv[1:])
