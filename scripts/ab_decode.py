"""Decode the same brick payloads with two checkouts of volpack in ONE process, brick by
brick in turn, and compare their CPU seconds per tool (best of ``--repeat`` per brick).

Two processes run one after the other see different loads on a shared machine (the
spread was 10-15 % from run to run here); in one process, with the two decoders taking
turns on each brick, a burst of load hits both alike. The base checkout's package is
copied under another name (``volpack_base``) into a temporary directory, so both import
side by side; the current one is the ``volpack`` on the path. Every payload is checked
to decode to its voxels with both.

    PYTHONPATH=. python scripts/ab_decode.py --base /work/main ct_head mri_ch2better \\
        --out results/lossless/arith8/kernel_ab.csv
"""

from __future__ import annotations

import argparse
import collections
import csv
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))


CODECS = {"lossless": ("lossless", "LosslessCodec"), "fast": ("fast", "FastCodec")}


def import_base(checkout: Path, where: Path, codec: str = "lossless"):
    """The base checkout's codec class (``--codec``), imported as ``volpack_base``."""
    dst = where / "volpack_base"
    shutil.copytree(checkout / "volpack", dst, ignore=shutil.ignore_patterns("__pycache__"))
    for p in dst.rglob("*.py"):  # the few absolute imports of the package itself
        s = p.read_text()
        t = re.sub(r"\b(from|import) volpack\b", r"\1 volpack_base", s)
        if t != s:
            p.write_text(t)
    sys.path.insert(0, str(where))
    import importlib

    module, cls = CODECS[codec]
    return getattr(importlib.import_module(f"volpack_base.volume_codec.{module}"), cls)


def bricks_of(name: str, blobs: Path | None, codec: str = "lossless"):
    """The codec's payloads of volume ``name`` with their voxels (the blob kept in
    ``blobs`` by ``bench_predict_decode.py``, ``NAME.vpk``, or for ``fast`` by
    ``bench_workers.py``, ``NAME.fast.vpk``, when there is one)."""
    import datasets

    from volpack import api
    from volpack.format.container import Reader
    from volpack.volume_codec import bricks

    a, _, _ = datasets.load(name)
    path = blobs / (f"{name}.vpk" if codec == "lossless" else f"{name}.{codec}.vpk") if blobs else None
    if path and path.exists():
        blob = path.read_bytes()
    else:
        blob = api.compress_array(np.ascontiguousarray(a), codec=codec)
    with Reader(blob) as r:
        bs = tuple(r.header["brick"])
        return [(bytes(r.read(e.t, e.node)), a[bricks.brick_slices(a.shape, bs, e.node)]) for e in r.entries]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("datasets", nargs="+")
    ap.add_argument("--base", type=Path, required=True, help="checkout to compare against")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--codec", choices=sorted(CODECS), default="lossless")
    ap.add_argument("--out", type=Path)
    ap.add_argument("--blobs", type=Path, help="bench_predict_decode.py's stored blobs, if any")
    args = ap.parse_args(argv)
    import importlib

    import volpack

    module, cls = CODECS[args.codec]
    mod = importlib.import_module(f"volpack.volume_codec.{module}")
    describe = mod.describe
    with tempfile.TemporaryDirectory() as tmp:
        a_codec, b_codec = import_base(args.base, Path(tmp), args.codec)(), getattr(mod, cls)()
        rows = []
        for name in args.datasets:
            items = bricks_of(name, args.blobs, args.codec)
            for p, b in items:
                for c in (a_codec, b_codec):
                    if not np.array_equal(c.decode(p, b.shape, b.dtype), b):
                        raise AssertionError(f"{name}: a brick did not decode to its voxels")
            ta = np.full(len(items), np.inf)
            tb = np.full(len(items), np.inf)
            for k in range(args.repeat):  # in turn, each first every other round (the
                for j, (p, b) in enumerate(items):  # second finds the payload in cache)
                    for c, best in ((a_codec, ta), (b_codec, tb))[:: 1 - 2 * (k & 1)]:
                        t = time.process_time()
                        c.decode(p, b.shape, b.dtype)
                        best[j] = min(best[j], time.process_time() - t)
            groups = collections.defaultdict(list)
            for j, (p, _) in enumerate(items):
                groups[describe(p)].append(j)
            for tool, js in sorted(groups.items()) + [("all", list(range(len(items))))]:
                nv = sum(items[j][1].size for j in js)
                sa, sb = ta[js].sum(), tb[js].sum()
                mb = nv * items[0][1].itemsize / 1e6
                row = {
                    "dataset": name, "tool": tool, "bricks": len(js), "voxels": nv,
                    "base_cpu_s": round(float(sa), 4), "cpu_s": round(float(sb), 4),
                    "base_mb_s": round(float(mb / sa), 2) if sa else "",
                    "mb_s": round(float(mb / sb), 2) if sb else "",
                    "speedup": round(float(sa / sb), 3) if sb else "", "load": f"{os.getloadavg()[0]:.1f}",
                }  # fmt: skip
                print(row, flush=True)
                rows.append(row)
    print("base", args.base, "current", Path(volpack.__file__).parent.parent)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with args.out.open("w", newline="") as f:
            w = csv.DictWriter(f, list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
