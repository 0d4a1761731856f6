"""Coded size of the default lossy streams with `arith` against `coder="arith2"` (the whole
volume coded each way, the payload each brick took shown): which cells a per-brick choice
of arith2 "only where it is not longer" would reach. One line per cell:

    PYTHONPATH=. python scripts/lossy_arith2_sizes.py > results/lossy/decode/arith2_sizes.txt
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_lossy_decode as bench  # noqa: E402
import datasets  # noqa: E402

from volpack import api  # noqa: E402


def main() -> None:
    for name in bench.FIELDS:
        a, _, _ = datasets.load(name)
        vrange = float(a.max()) - float(a.min())
        for rel in bench.RELS:
            e = float(f"{vrange * rel:.4g}")
            x1 = api.compress_array(a, max_error=e)
            x2 = api.compress_array(a, max_error=e, coder="arith2")
            print(
                f"{name:15s} {rel:6g} arith {len(x1):7d} {bench.payload_paths(x1):35s} "
                f"arith2 {len(x2):7d} {bench.payload_paths(x2):35s} "
                f"size {100 * (len(x2) / len(x1) - 1):+.2f}%",
                flush=True,
            )


if __name__ == "__main__":
    main()
