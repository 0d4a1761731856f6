"""Each cell's payload kind in detail (kinds.csv): bench_lossy_decode's label, with the
quantised voxels' coding spelled out: ``longfit(static)`` / ``longfit(adaptive)`` /
``longfit(lossless)`` (the long fitted predictor, its residual by type 4, type 3, or the
lossless codec) or ``qvox(lossless)`` (the lossless codec on the quantised voxels).

    PYTHONPATH=. python results/lossy/ldec31/kinds.py > results/lossy/ldec31/kinds.csv
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import cells  # noqa: E402
from bench_lossy_decode import payload_paths  # noqa: E402

from volpack.format.container import Reader  # noqa: E402
from volpack.format.sections import take_section  # noqa: E402

RESIDUAL = {3: "adaptive", 4: "static"}


def kind(blob: bytes) -> str:
    out = set()
    with Reader(blob) as r:
        for _t, _node, p in r:
            flags = p[0]
            if flags & (16 | 64 | 128 | 4):
                continue
            inner = bytes(take_section(memoryview(p), 1, "inner")[0])
            if flags & 8:
                code = inner[4] if inner[0] == 0 else inner[1]
                out.add(f"longfit({RESIDUAL.get(code, 'lossless')})")
            else:
                out.add("qvox(lossless)")
    return "+".join(sorted(out))


if __name__ == "__main__":
    import csv

    w = csv.writer(sys.stdout, lineterminator="\n")
    w.writerow(["field", "rel", "payload", "quantised"])
    for name in cells.TUNE + cells.HELDOUT:
        for rel in cells.RELS:
            b = cells.blob(name, rel)
            w.writerow([name, f"{rel:g}", payload_paths(b), kind(b)])
