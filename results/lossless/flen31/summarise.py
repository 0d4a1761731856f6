"""Markdown tables of ab.py's CSVs: bytes and CPU seconds before (the base tree) and
after (the default, pruned), per volume, and the totals.

    python results/lossless/flen31/summarise.py results/lossless/flen31/ab_tune.csv
"""

from __future__ import annotations

import csv
import math
import sys


def main() -> None:
    for path in sys.argv[1:]:
        rows = list(csv.DictReader(open(path)))
        print(f"{path}\n\n| volume | bytes before -> after | CPU s before -> exact -> pruned | x |")
        print("|---|---|---|---:|")
        logs, b0, b1, c0, c1 = [], 0, 0, 0.0, 0.0
        worst = (-math.inf, "")
        for r in rows:
            nb, na = int(r["bytes_before"]), int(r["bytes_pruned"])
            cb, ce, cp = float(r["cpu_before"]), float(r["cpu_exact"]), float(r["cpu_pruned"])
            d = 100 * (na / nb - 1)
            worst = max(worst, (d, r["volume"]))
            logs.append(math.log(cb / cp))
            b0, b1, c0, c1 = b0 + nb, b1 + na, c0 + cb, c1 + cp
            print(
                f"| {r['volume']} ({r['shape']}) | {nb:,} -> {na:,} ({d:+.3f} %) | "
                f"{cb:.2f} -> {ce:.2f} -> {cp:.2f} | {cb / cp:.2f} |"
            )
        g = math.exp(sum(logs) / len(logs))
        print(
            f"\ngeometric mean {g:.2f}x over {len(rows)} volumes; CPU {c0:.2f} -> {c1:.2f} s in all; "
            f"bytes {100 * (b1 / b0 - 1):+.3f} % in all, worst {worst[0]:+.3f} % ({worst[1]})\n"
        )


if __name__ == "__main__":
    main()
