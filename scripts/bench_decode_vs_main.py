"""Decode CPU seconds of this checkout's lossless decoder against another checkout's (main),
both imported in one process, interleaved, best of ``--repeat``, one worker.

The other checkout is imported as a second package, ``volpack_main``: copy its ``volpack``
folder to ``DIR/volpack_main`` and rename the package inside, e.g.

    cp -r /work/main/volpack /tmp/mainpkg/volpack_main
    find /tmp/mainpkg/volpack_main -name '*.py' -exec sed -i 's/\\bfrom volpack\\./from volpack_main./g;
        s/\\bfrom volpack import/from volpack_main import/g' {} +
    sed -i 's/"volpack\\./"volpack_main./g' /tmp/mainpkg/volpack_main/__init__.py /tmp/mainpkg/volpack_main/kinds.py
    python scripts/bench_decode_vs_main.py --main /tmp/mainpkg mri_dipy_s0 brainsmall

For each volume: the other checkout's default file decoded by it and by this checkout, and
this checkout's files (brick 64 and its default) decoded by this checkout.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("datasets", nargs="+", metavar="NAME")
    ap.add_argument("--main", type=Path, required=True, help="folder holding volpack_main")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    sys.path.insert(0, str(args.main))
    from volpack_main import api as old  # type: ignore[import-not-found]

    from volpack import api as new

    for name in args.datasets:
        a, _, _ = datasets.load(name)
        b_main = old.compress_array(a)
        cases = [
            ("main decodes main", old, b_main),
            ("branch decodes main", new, b_main),
            ("branch decodes brick 64", new, new.compress_array(a, brick=64)),
            ("branch decodes its default", new, new.compress_array(a)),
        ]
        for _, m, b in cases:  # (also compiles)
            if not np.array_equal(m.decompress_array(b, workers=1), a):
                raise AssertionError(f"{name}: no round trip")
        best = [float("inf")] * len(cases)
        for _ in range(args.repeat):
            for k, (_, m, b) in enumerate(cases):
                t = time.process_time()
                m.decompress_array(b, workers=1)
                best[k] = min(best[k], time.process_time() - t)
        mb = a.nbytes / 1e6
        print(f"{name} {a.shape} {a.dtype}: bytes " + " ".join(str(len(b)) for _, _, b in cases))
        for (label, _, _), t in zip(cases, best):
            print(f"  {label:28s} {t:7.3f} CPU s {mb / t:7.2f} MB/s ({t / best[0]:.3f}x main)")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
