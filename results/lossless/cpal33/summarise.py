"""measure.csv as the README's markdown table.

    python results/lossless/cpal33/summarise.py results/lossless/cpal33/measure.csv
"""

from __future__ import annotations

import csv
import sys


def main(path: str) -> None:
    rows = list(csv.DictReader(open(path)))
    print("| volume | shape | tuples (order) | ratio before -> after | gain | best peer (ratio) "
          "| x best peer before -> after | encode CPU s | decode CPU s |")
    print("|---|---|---|---|---:|---|---|---|---|")
    for r in rows:
        name = r["volume"] + (" (tuned on)" if r["tuned"] == "True" else "")
        tup = f"{r['tuples']} ({r['order']})" if r["tuples"] else "none"
        print(
            f"| {name} | {r['dtype']} {r['shape']} | {tup} | {r['before_ratio']} -> "
            f"{r['after_ratio']} | {r['gain']}x | {r['best_peer']} ({r['best_peer_ratio']}) | "
            f"{r['before_x_peer']} -> **{r['after_x_peer']}** | {r['before_enc_cpu_s']} -> "
            f"{r['after_enc_cpu_s']} | {r['before_dec_cpu_s']} -> {r['after_dec_cpu_s']} |"
        )


if __name__ == "__main__":
    main(sys.argv[1])
