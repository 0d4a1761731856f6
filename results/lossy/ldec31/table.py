"""The README / findings tables from ab.py's CSVs (and the payload kinds of
kinds.csv): python results/lossy/ldec31/table.py ab_tune.csv ab_heldout.csv"""

import csv
import math
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(paths):
    kinds = {}
    with (HERE / "kinds.csv").open() as f:
        for r in csv.DictReader(f):
            kinds[(r["field"], r["rel"])] = r["quantised"] or r["payload"]
    for p in paths:
        rows = list(csv.DictReader(Path(p).open()))
        print(f"\n{Path(p).name}:\n")
        print("| field | E/range | payload | ratio | ms base -> branch | speedup | MB/s base -> branch"
              " | SZ3 ms | x SZ3 base -> branch | same voxels |")
        print("|---|---:|---|---:|---:|---:|---:|---:|---:|---|")
        for r in rows:
            sz3 = min(float(r["ms_sz3_base"]), float(r["ms_sz3_branch"]))
            print(f"| {r['field']} | {r['rel']} | {kinds.get((r['field'], r['rel']), '?')} | {r['ratio']}"
                  f" | {float(r['ms_base']):.2f} -> {float(r['ms_branch']):.2f} | {r['speedup']}"
                  f" | {r['MBps_base']} -> {r['MBps_branch']} | {sz3:.2f}"
                  f" | {r['x_sz3_base']} -> {r['x_sz3_branch']} | {r['same']} |")
        sp = [float(r["speedup"]) for r in rows]
        xb = [float(r["x_sz3_base"]) for r in rows]
        xa = [float(r["x_sz3_branch"]) for r in rows]
        g = lambda v: math.exp(sum(map(math.log, v)) / len(v))  # noqa: E731
        changed = [s for s, r in zip(sp, rows) if "longfit" in kinds.get((r["field"], r["rel"]), "")]
        print(f"\ncells {len(rows)}; geometric mean speedup {g(sp):.3f}; x SZ3 {g(xb):.3f} -> {g(xa):.3f};"
              f" >= 0.5x SZ3: {sum(x >= 0.5 for x in xb)} -> {sum(x >= 0.5 for x in xa)};"
              f" same voxels {sum(r['same'] == 'True' for r in rows)}/{len(rows)}"
              + (f"; long-fit cells {len(changed)}: speedup {min(changed):.2f}-{max(changed):.2f},"
                 f" geometric mean {g(changed):.3f}" if changed else ""))


if __name__ == "__main__":
    main(sys.argv[1:])
