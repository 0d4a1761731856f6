"""Markdown table of an ab.py CSV: bytes and CPU seconds before -> pruned per volume, and
the geometric mean of the speed-ups.

    python results/lossless/lenc30/summarise.py results/lossless/lenc30/ab_tune.csv
"""

from __future__ import annotations

import csv
import math
import sys
from pathlib import Path


def main() -> None:
    by: dict = {}
    for r in csv.DictReader(open(sys.argv[1])):
        by.setdefault(r["volume"], {})[r["mode"]] = r
    print(
        "| volume | shape, dtype | bytes before -> after | CPU s before -> after | exhaustive today |"
    )
    print("|---|---|---|---|---|")
    logs, worst, total = [], -math.inf, [0, 0]
    for name, m in by.items():
        b, p = m["before"], m["pruned"]
        nb, np_ = int(b["bytes"]), int(p["bytes"])
        tb, tp = float(b["cpu_s"]), float(p["cpu_s"])
        logs.append(math.log(tb / tp))
        worst = max(worst, np_ / nb - 1)
        total[0] += nb
        total[1] += np_
        ex = m.get("exhaustive")
        ex_s = f"{float(ex['cpu_s']):.2f} s, same bytes: {ex['same_as_before']}" if ex else "-"
        print(
            f"| {Path(name).stem} | {b['shape']} {b['dtype']} | {nb:,} -> {np_:,} ({100 * (np_ / nb - 1):+.3f} %) "
            f"| {tb:.2f} -> {tp:.2f} ({tb / tp:.2f}x) | {ex_s} |"
        )
    print(
        f"\ngeometric mean {math.exp(sum(logs) / len(logs)):.2f}x over {len(logs)} volumes; "
        f"bytes {100 * (total[1] / total[0] - 1):+.3f} % in all, worst file {100 * worst:+.3f} %"
    )


if __name__ == "__main__":
    main()
