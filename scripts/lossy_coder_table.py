"""The per-cell table of the coefficient coders' round (README, "Lossy decoding, part 5").

Reads ``decode.csv`` of ``scripts/bench_lossy_decode.py`` runs labelled ``arith`` (the
old default, ``--coder arith``), ``auto`` (the new default) and, if present, ``arith2``
and ``static`` (``--coder arith2`` / ``static``), and prints, per field and bound, the
ratio and the decoding speed (MB/s, x SPERR, x SZ3, each against the peers of its own
run) of each, then the counts against the goals and geometric means.

    python scripts/lossy_coder_table.py results/lossy/lossy9/decode.csv
"""

from __future__ import annotations

import csv
import math
import sys
from collections import defaultdict


def main(path: str) -> None:
    with open(path) as f:
        rows = list(csv.DictReader(f))
    by = defaultdict(dict)
    for r in rows:
        by[(r["dataset"], r["rel_bound"])][r["label"]] = r
    labels = [x for x in ("arith", "auto", "arith2", "static") if any(x in v for v in by.values())]
    head = " / ".join(labels)
    print(f"| field | E/range | payload (auto) | ratio {head} | decode MB/s {head} | "
          f"x SPERR {head} | x SZ3 {head} | encode MB/s arith / auto |")
    print("|---|---:|---|---:|---:|---:|---:|---:|")
    for (name, rel), cell in by.items():
        def col(key, fmt):
            return " / ".join(fmt.format(float(cell[x][key])) if x in cell else "-" for x in labels)

        enc = " / ".join(
            f"{float(cell[x]['encode_MBps_volpack']):.2f}"
            if x in cell and cell[x]["encode_MBps_volpack"] else "-"
            for x in ("arith", "auto")
        )
        print(f"| {name} | {rel} | {cell.get('auto', cell[labels[0]])['path']} | "
              f"{col('ratio_volpack', '{:.2f}')} | {col('decode_MBps_volpack', '{:.0f}')} | "
              f"{col('x_sperr', '{:.2f}')} | {col('x_sz3', '{:.2f}')} | {enc} |")
    print()
    for x in labels:
        cells = [c[x] for c in by.values() if x in c]
        xs = [float(c["x_sperr"]) for c in cells]
        xz = [float(c["x_sz3"]) for c in cells]
        g = lambda v: math.exp(sum(map(math.log, v)) / len(v))  # noqa: E731
        print(f"{x}: {len(cells)} cells; >= SPERR in {sum(v >= 1 for v in xs)}, >= half SZ3 in "
              f"{sum(v >= 0.5 for v in xz)}; geometric mean x SPERR {g(xs):.2f}, x SZ3 {g(xz):.2f}")
    if "arith" in labels and "auto" in labels:
        d = [float(c["auto"]["ratio_volpack"]) / float(c["arith"]["ratio_volpack"]) - 1
             for c in by.values() if "auto" in c and "arith" in c]
        print(f"auto vs arith ratio: {100 * min(d):+.2f} .. {100 * max(d):+.2f} %")


if __name__ == "__main__":
    main(sys.argv[1])
