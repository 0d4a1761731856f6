"""Lead of volpack's default and of effort 'max' over the best of SPERR, SZ3 and SZ3's
best predictor, per field and bound: the peers of an earlier run (same arrays, same
script), the default's rows of session 20's main (lossy20) and this run's volpack-max.

    python results/lossy/max20/leads.py PEERS.csv DEFAULT.csv MAX.csv
"""

import csv
import math
import sys

PEERS = ("sperr", "sz3", "sz3-best")


def rows(path):
    with open(path, newline="") as f:
        return [r for r in csv.DictReader(f) if r["bound"]]


def main():
    peers, default, best_max = (rows(p) for p in sys.argv[1:4])
    best, ours, mx, ok = {}, {}, {}, {}
    for r in peers:
        if r["method"] in PEERS:
            k = (r["dataset"], float(r["bound"]))
            best[k] = max(best.get(k, 0.0), float(r["ratio"]))
    for r in default:
        if r["method"] == "volpack":
            ours[(r["dataset"], float(r["bound"]))] = float(r["ratio"])
    for r in best_max:
        if r["method"] == "volpack-max":
            k = (r["dataset"], float(r["bound"]))
            mx[k] = float(r["ratio"])
            ok[k] = r["bound_ok"]
    keys = [k for k in mx if k in best and k in ours]
    print("| field | bound | default | max | gain | best peer | default lead | max lead | bound |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---|")
    for k in keys:
        d, m, b = ours[k], mx[k], best[k]
        print(f"| {k[0]} | {k[1]:.4g} | {d:.3f} | {m:.3f} | {100 * (m / d - 1):+.2f} % | {b:.3f} "
              f"| {d / b:.3f} | {m / b:.3f} | {ok[k]} |")
    for name, src in (("default", ours), ("max", mx)):
        leads = [src[k] / best[k] for k in keys]
        gm = math.exp(sum(math.log(x) for x in leads) / len(leads))
        print(f"{name}: {sum(x >= 1.1 for x in leads)} of {len(leads)} at 1.1x, "
              f"geomean {gm:.3f}, lowest {min(leads):.3f}")


main()
