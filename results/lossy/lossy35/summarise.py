"""Print the trial's markdown tables and draw its chart.

Run: python results/lossy/lossy35/summarise.py trial_base.csv [trial_after.csv] [--chart OUT.png]
One CSV: a table of every cell. Two: before -> after for the cells of the second.
Or: summarise.py --grid A.csv [B.csv ...]: x best of SZ3/SPERR per field and bound, later
CSVs' cells replacing earlier ones.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path


def rows_of(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def num(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return None


def table(rows):
    print("| field | set | E (of range) | volpack bytes | ratio | x best of SZ3/SPERR (peer) "
          "| PSNR dB | max err / E | SZ3 bytes | SPERR bytes | dec MB/s volpack / SZ3 / SPERR |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if r.get("rc") not in ("0", 0, None, ""):
            print(f"| {r['field']} | {r['set']} | {r['rel']} | error: {r.get('error')} |||||||||")
            continue
        me = num(r["max_error"]) / num(r["bound"]) if num(r["bound"]) else float("nan")
        sperr = r.get("sperr_bytes", "") + ("" if r.get("sperr_ok") == "True" else " (bound broken)")
        sz3 = r.get("sz3_bytes", "") + ("" if r.get("sz3_ok") == "True" else " (bound broken)")
        psnr = r["psnr"] or "exact"
        xb = f"{num(r['x_best']):.3f} ({r['best_peer']})" if num(r.get("x_best")) else "no peer held the bound"
        print(f"| {r['field']} | {r['set']} | {r['rel']} | {int(r['bytes']):,} | {num(r['ratio']):.1f} "
              f"| {xb} | {psnr} | {me:.3f} | {sz3} | {sperr} "
              f"| {r['dec_mb_s']} / {r.get('sz3_dec_mb_s')} / {r.get('sperr_dec_mb_s')} |")  # fmt: skip
    xs = [num(r["x_best"]) for r in rows if num(r.get("x_best"))]
    print(f"\n{len(xs)} cells: {sum(x >= 1.1 for x in xs)} at >= 1.1x the best of SZ3/SPERR, "
          f"{sum(x < 1.0 for x in xs)} below it; min {min(xs):.3f}")  # fmt: skip


def versus(before, after):
    b = {(r["field"], r["rel"]): r for r in before}
    print("| field | E | bytes before -> after | x best before -> after |")
    print("|---|---|---|---|")
    for r in after:
        o = b.get((r["field"], r["rel"]))
        if o is None:
            continue
        print(f"| {r['field']} | {r['rel']} | {int(o['bytes']):,} -> {int(r['bytes']):,} "
              f"| {o.get('x_best')} -> {r.get('x_best')} |")  # fmt: skip


def chart(rows, out):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fields = list(dict.fromkeys(r["field"] for r in rows))
    n = len(fields)
    cols = 4
    fig, axes = plt.subplots((n + cols - 1) // cols, cols, figsize=(16, 3.6 * ((n + cols - 1) // cols)))
    for ax, f in zip(axes.flat, fields):
        rs = [r for r in rows if r["field"] == f and r.get("rc") in ("0", "")]
        e = [num(r["rel"]) for r in rs]
        raw = [num(r["ratio"]) * num(r["bytes"]) for r in rs]
        ax.loglog(e, [num(r["ratio"]) for r in rs], "o-", label="volpack")
        for p, m in (("sz3", "s--"), ("sperr", "^--"), ("zfp", "x:")):
            pts = [(ei, w / num(r[f"{p}_bytes"])) for ei, w, r in zip(e, raw, rs)
                   if num(r.get(f"{p}_bytes")) and r.get(f"{p}_ok") == "True"]  # fmt: skip
            if pts:
                ax.loglog(*zip(*pts), m, label=p)
        ax.set_title(f + (" (held out)" if rs and rs[0]["set"] == "held-out" else ""), fontsize=9)
        ax.set_xlabel("max error / range")
        ax.set_ylabel("ratio")
        ax.invert_xaxis()
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=80)


def main():
    args = sys.argv[1:]
    out = None
    if "--chart" in args:
        i = args.index("--chart")
        out = args[i + 1]
        del args[i : i + 2]
    rows = [r for p in args[:1] for r in rows_of(p)]
    if len(args) == 1:
        table(rows)
    else:
        after = rows_of(args[1])
        table(after)
        print()
        versus(rows, after)
    if out:
        chart(rows if len(args) == 1 else rows_of(args[1]), Path(out))




def grid(paths):
    """One row per field: x best of SZ3/SPERR at each bound, later CSVs' cells replacing
    earlier ones ("before -> after" where they differ)."""
    cells, order = {}, []
    for p in paths:
        for r in rows_of(p):
            k = (r["field"], r["rel"])
            if r["field"] not in order:
                order.append(r["field"])
            x = num(r.get("x_best"))
            v = f"{x:.3f}" if x else "no peer"
            if k in cells and cells[k][0] != v:
                v = f"{cells[k][0]} -> {v}"
            cells[k] = (v, r["set"], r["ratio"])
    print("| field | set | 1e-2 | 1e-3 | 1e-4 | 1e-5 |")
    print("|---|---|---|---|---|---|")
    for f in order:
        vals = [cells.get((f, e)) for e in ("1e-2", "1e-3", "1e-4", "1e-5")]
        print(f"| {f} | {vals[0][1]} | " + " | ".join(f"{v[0]} ({float(v[2]):.1f}:1)" for v in vals) + " |")


if __name__ == "__main__":
    if sys.argv[1] == "--grid":
        grid(sys.argv[2:])
    else:
        main()
