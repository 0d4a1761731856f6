"""How well the central slab ranks the variants of ``variants.csv``: for each decision of
the chain, per margin, how often the slab decides it (|estimated gain| above the margin),
how often it then decides wrongly, and the bytes that costs (against the full sizes).

    python results/lossless/lenc30/analyze.py results/lossless/lenc30/variants.csv
"""

from __future__ import annotations

import csv
import sys
from collections import defaultdict

MIX_MIN_SAVING = 0.003
MARGINS = (0.0, 0.005, 0.01, 0.02, 0.03, 0.05)


def bricks(path):
    out = defaultdict(dict)
    for r in csv.DictReader(open(path)):
        key = (r["volume"], int(r["brick"]))
        out[key][r["variant"]] = (int(r["full"]), float(r["sample"]) if r["sample"] else None)
    return out


def decisions(b):
    """(name, full without, full with, sample without, sample with, threshold) per decision."""
    if "values" not in b:
        return []
    out = []
    dom = [k for k in ("values", "ranks") if k in b]
    best = min(b[k][0] for k in dom)
    sbest = min(b[k][1] for k in dom)  # the slab's sizes lack the heads: compare streams
    if len(dom) == 2:
        out.append(("ranks", b["values"][0], b["ranks"][0], b["values"][1], b["ranks"][1], 0.0))
    chain_full, chain_s = best, sbest
    for k in ("mask", "one", "low", "tex", "mix"):
        if k not in b:
            continue
        f, s = b[k]
        out.append((k, chain_full, f, chain_s, s, MIX_MIN_SAVING if k == "mix" else 0.0))
        th = MIX_MIN_SAVING if k == "mix" else 0.0
        if f < (1 - th) * chain_full:
            chain_full, chain_s = f, s
    for k in ("v1", "v1ranks", "wavelet"):
        if k in b:
            out.append((k, chain_full, b[k][0], chain_s, b[k][1], 0.0))
    return out


def main():
    data = bricks(sys.argv[1])
    total = defaultdict(int)
    for b in data.values():
        best = min(
            v[0]
            for k, v in b.items()
            if k
            in ("values", "ranks", "mask", "one", "low", "tex", "mix", "v1", "v1ranks", "wavelet")
        )
        total["bytes"] += best
    print(f"bricks {len(data)}, best bytes {total['bytes']}")
    for m in MARGINS:
        stats = defaultdict(lambda: [0, 0, 0, 0])  # n, decided, wrong, bytes lost
        for b in data.values():
            for name, f0, f1, s0, s1, th in decisions(b):
                st = stats[name]
                st[0] += 1
                gain = 1 - s1 / s0  # the slab's share saved by the variant
                if abs(gain - th) <= m:
                    continue
                st[1] += 1
                take = gain > th
                full_take = f1 < (1 - th) * f0
                if take != full_take:
                    st[2] += 1
                    st[3] += abs(f1 - f0)
        line = ", ".join(f"{k} {v[1]}/{v[0]} wrong {v[2]} lost {v[3]}" for k, v in stats.items())
        print(f"margin {m}: {line}")


if __name__ == "__main__":
    main()
