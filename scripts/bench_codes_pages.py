"""User and system CPU of a walk's first frame with the normal-code array on numpy's own
pages (2 MB pages for arrays of 4 MB and more, as volpack allocates it) or on small (4 kB)
pages (an anonymous ``mmap`` of its own), each in a fresh process, alternating.

Each child runs ``volpack walk T.vpk OUT/ --orbit 1`` in its process and reports, from
``getrusage``, the user and system CPU and minor faults of ``NormalCodes.ensure`` (the
codes of the first frame) and of the whole first ``render_lod`` call. Appends CSV rows
to ``--out``.

    python scripts/bench_codes_pages.py o.vpk --rounds 6 --out pages.csv
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import io
import json
import os
import resource
import sys
import tempfile
from pathlib import Path


def child(vpk: str, pages: str) -> dict:
    import numpy as np

    from volpack.cli import main as cli
    from volpack.render import lod, normals

    if pages == "small":  # zero pages of a mapping numpy did not ask 2 MB pages for
        import mmap

        init = normals.NormalCodes.__init__

        def small_pages(self, vol, spacing):
            init(self, vol, spacing)
            buf = mmap.mmap(-1, self.codes.nbytes)
            self.codes = np.frombuffer(buf, np.uint16).reshape(vol.shape)

        normals.NormalCodes.__init__ = small_pages
    got: dict = {}

    def usage():
        r = resource.getrusage(resource.RUSAGE_SELF)
        return r.ru_utime, r.ru_stime, r.ru_minflt

    def first(owner, name, label):
        fn = getattr(owner, name)

        @functools.wraps(fn)
        def wrapper(*a, **k):
            if label in got:
                return fn(*a, **k)
            u0 = usage()
            try:
                return fn(*a, **k)
            finally:
                got[label] = [b - a for a, b in zip(u0, usage())]

        setattr(owner, name, wrapper)

    first(normals.NormalCodes, "ensure", "codes")
    first(lod, "render_lod", "frame0")
    with contextlib.redirect_stdout(io.StringIO()):
        cli(["walk", vpk, tempfile.mkdtemp() + "/", "--orbit", "1"], standalone_mode=False)
    return {f"{k}_{m}": round(1e3 * v[i], 1) if i < 2 else v[i]
            for k, v in got.items() for i, m in enumerate(("user_ms", "sys_ms", "faults"))}  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("vpk")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--child", choices=["small", "numpy"], help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(child(args.vpk, args.child)))
        return 0
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_normal_codes import alternate
    from bench_workers import append_csv

    runs = [({"pages": pages}, [__file__, args.vpk, "--child", pages], None)
            for pages in ("numpy", "small")]  # fmt: skip
    rows = alternate(runs, args.rounds)
    if args.out:
        append_csv(rows, args.out)
    return 0

if __name__ == "__main__":
    raise SystemExit(main())
