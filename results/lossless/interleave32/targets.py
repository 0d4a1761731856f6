"""4-D series under a PSNR or ratio target: each time step alone against the default.

Session 32 let PSNR and ratio targets take the interleaved layout (the setting searched on
the time steps, the layout chosen at it, the search run again on the stored volume). For
every series of interleave31's measure.py and heldout.py (the large held-out ones cut as
interleave31's lossy.py cuts them): volpack with ``interleave=False`` and the default, at
PSNR 40, 50, 60 dB and ratios 10 and 30; each file decoded and its PSNR (the value range
as peak, every voxel) and file ratio measured here. Writes OUT.csv and OUT.md.

Run: PYTHONPATH=. python results/lossless/interleave32/targets.py OUT_STEM
"""

from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE.parent / "interleave31"))

import heldout  # noqa: E402
import measure  # noqa: E402
from lossy import CUTS  # noqa: E402

from volpack import api  # noqa: E402

TARGETS = (("psnr", 40.0), ("psnr", 50.0), ("psnr", 60.0), ("ratio", 10.0), ("ratio", 30.0))


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    a, b = a.astype(np.float64), b.astype(np.float64)
    mse = float(np.mean((a - b) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10((a.max() - a.min()) ** 2 / mse)


def main(stem: str) -> None:
    rows = []
    for name, split, a in measure.series() + heldout.series():
        a = np.ascontiguousarray(a[CUTS.get(name, (slice(None),))])
        for what, value in TARGETS:
            row = {"series": name, "split": split, "shape": "x".join(map(str, a.shape)),
                   "dtype": a.dtype.name, "target": what, "value": value, "raw": a.nbytes}  # fmt: skip
            for key, opt in (("frames", False), ("default", None)):
                t0 = time.process_time()
                blob = api.compress_array(a, **{what: value}, interleave=opt, workers=1)
                row[f"{key}_cpu_s"] = round(time.process_time() - t0, 3)
                back = api.decompress_array(blob)
                row[f"{key}_bytes"] = len(blob)
                row[f"{key}_psnr"] = round(psnr(a, back), 3)
                if key == "default":
                    row["default_layout"] = api.info(blob)["header"].get("layout", "frames")
            rows.append(row)
            print(f"{name:24s} {what} {value:g}: frames {row['frames_bytes']:>9d} B "
                  f"{row['frames_psnr']:.2f} dB {row['frames_cpu_s']:.1f} s | default "
                  f"{row['default_layout']:>11s} {row['default_bytes']:>9d} B "
                  f"{row['default_psnr']:.2f} dB {row['default_cpu_s']:.1f} s", flush=True)  # fmt: skip
    with open(f"{stem}.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [
        "| series | split | shape, dtype | target | each alone: ratio, PSNR | default: layout, "
        "ratio, PSNR | bytes each alone / default | CPU s each alone / default |",
        "|---|---|---|---|---|---|---:|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['series']} | {r['split']} | {r['shape']} {r['dtype']} | {r['target']} "
            f"{r['value']:g} | {r['raw'] / r['frames_bytes']:.2f}, {r['frames_psnr']:.2f} dB | "
            f"{r['default_layout']}, {r['raw'] / r['default_bytes']:.2f}, "
            f"{r['default_psnr']:.2f} dB | {r['frames_bytes'] / r['default_bytes']:.3f}x | "
            f"{r['frames_cpu_s']:.1f} / {r['default_cpu_s']:.1f} |"
        )
    Path(f"{stem}.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
