"""Per cell: bytes and encode CPU seconds before -> after, the ratios, and the geometric
mean speed-up. Either two bench.py CSVs (before, after) or one ab.py CSV (exhaustive,
pruned: the same process, interleaved).

    python results/lossy/enc29/compare.py BEFORE.csv AFTER.csv [--md]
    python results/lossy/enc29/compare.py AB.csv [--md]"""

import csv
import math
import sys

md = "--md" in sys.argv
paths = [a for a in sys.argv[1:] if a != "--md"]
if len(paths) == 1:
    pairs = [
        (r["field"], r["rel"], r["bytes_exhaustive"], r["bytes_pruned"], r["cpu_exhaustive"],
         r["cpu_pruned"])
        for r in csv.DictReader(open(paths[0]))
    ]  # fmt: skip
else:
    after = {(r["field"], r["rel"]): r for r in csv.DictReader(open(paths[1]))}
    pairs = [
        (r["field"], r["rel"], r["bytes"], after[k]["bytes"], r["cpu_s"], after[k]["cpu_s"])
        for r in csv.DictReader(open(paths[0]))
        if (k := (r["field"], r["rel"])) in after
    ]
if md:
    print("| field | rel | bytes before -> after | % | CPU s before -> after | x |")
    print("|---|---|---|---|---|---|")
logs, worst, total = [], -math.inf, [0, 0]
for field, rel, b0, b1, t0, t1 in pairs:
    d = (int(b1) / int(b0) - 1) * 100
    x = float(t0) / float(t1)
    logs.append(math.log(x))
    worst = max(worst, d)
    total[0] += int(b0)
    total[1] += int(b1)
    if md:
        print(f"| {field} | {rel} | {b0} -> {b1} | {d:+.2f} | {t0} -> {t1} | {x:.2f} |")
    else:
        print(f"{field:18} {rel:7} {b0:>9} -> {b1:>9} {d:+6.2f}%  {t0:>7} -> {t1:>7} s {x:5.2f}x")
g = math.exp(sum(logs) / len(logs))
print(
    f"\n{len(logs)} cells: geometric mean speed-up {g:.2f}x (range {math.exp(min(logs)):.2f}-"
    f"{math.exp(max(logs)):.2f}x), worst cell {worst:+.2f} %, all bytes "
    f"{(total[1] / total[0] - 1) * 100:+.3f} %"
)
