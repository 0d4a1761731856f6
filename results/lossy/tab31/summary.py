"""tab31: the A/B tables (ab_*.csv, ldec31's ab.py) split by whether a cell's decode runs
the arith decoder (cold.csv's count), with the first-decode (cold) speedups beside.

    python results/lossy/tab31/summary.py > results/lossy/tab31/table.md
"""

import csv
import math
from pathlib import Path

HERE = Path(__file__).resolve().parent


def rows(name):
    with (HERE / name).open() as f:
        return list(csv.DictReader(f))


def geo(xs):
    return math.exp(sum(math.log(x) for x in xs) / len(xs))


cold = {(r["field"], f"{float(r['rel']):g}"): r for r in rows("cold.csv")}
print("| set | field | E/range | arith decodes | ms base -> branch | speedup (warm) | "
      "x SZ3 base -> branch | first decode: speedup (cold) | same voxels |")
print("|---|---|---:|---:|---:|---:|---:|---:|---|")
summary = []
for tag, name in (("tuning", "ab_tune.csv"), ("held out", "ab_heldout.csv")):
    ab = rows(name)
    for r in ab:
        c = cold[(r["field"], r["rel"])]
        print(f"| {tag} | {r['field']} | {r['rel']} | {c['arith_decodes']} | {float(r['ms_base']):.2f} -> "
              f"{float(r['ms_branch']):.2f} | {r['speedup']} | {r['x_sz3_base']} -> {r['x_sz3_branch']} | "
              f"{c['speedup_cold']} | {r['same']} |")  # fmt: skip
    for kind, pick in (("arith", lambda n: n > 0), ("other", lambda n: n == 0)):
        sel = [r for r in ab if pick(int(cold[(r["field"], r["rel"])]["arith_decodes"]))]
        sp = [float(r["speedup"]) for r in sel]
        cs = [float(cold[(r["field"], r["rel"])]["speedup_cold"]) for r in sel]
        xb = [float(r["x_sz3_base"]) for r in sel]
        xr = [float(r["x_sz3_branch"]) for r in sel]
        summary.append(f"| {tag} | {kind} | {len(sel)} | {min(sp):.3f}-{max(sp):.3f} (geo. mean "
                       f"{geo(sp):.3f}) | {geo(xb):.3f} -> {geo(xr):.3f} | {min(cs):.3f}-{max(cs):.3f} | "
                       f"{sum(r['same'] == 'True' for r in sel)}/{len(sel)} |")  # fmt: skip
print()
print("| set | cells | n | speedup, warm (ab.py) | x SZ3 geo. mean | speedup, cold (cold.py) | same |")
print("|---|---|---:|---:|---:|---:|---:|")
print("\n".join(summary))
ct = cold[("ct_head", "0")]
print(f"\nct_head lossless ({ct['voxels']} voxels, ratio {ct['ratio']}): {ct['arith_decodes']} arith "
      f"decodes; {ct['ms_base']} -> {ct['ms_branch_warm']} ms warm ({ct['speedup_warm']}x), "
      f"{ct['ms_branch_cold']} cold ({ct['speedup_cold']}x); exact {ct['exact']}, same {ct['same']}")  # fmt: skip
print("\nThe cells that run arith again, 7 turns x 5 decodes (cold_arith.csv; climate_t and "
      "cam_u at 1e-3, no arith, as controls):\n")
print("| field | E/range | arith payload, bits a coefficient | ms base | ms branch, warm | ms branch, cold | "
      "speedup warm | speedup cold | same |")
print("|---|---:|---:|---:|---:|---:|---:|---:|---|")
BITS = {("climate_t", "0.01"): 0.270, ("climate_t", "1e-05"): 5.629, ("hgt_500", "0.01"): 0.177,
        ("hgt_500", "0.001"): 0.832, ("ct_skull_float", "0.01"): 0.320, ("tgv128", "1e-05"): 8.265,
        ("cam_u", "0.01"): 0.335, ("cam_u", "1e-05"): 5.627, ("seam_ps", "0.01"): 0.391,
        ("seam_ps", "0.001"): 1.947}  # sizes.py  # fmt: skip
for r in rows("cold_arith.csv"):
    b = BITS.get((r["field"], r["rel"]))
    print(f"| {r['field']} | {r['rel']} | {'-' if b is None else b} | {r['ms_base']} | {r['ms_branch_warm']} | "
          f"{r['ms_branch_cold']} | {r['speedup_warm']} | {r['speedup_cold']} | {r['same']} |")  # fmt: skip
