"""Markdown rows of measure.py's CSVs: ``python table.py A.csv [B.csv ...]``."""

from __future__ import annotations

import csv
import sys

HEAD = (
    "| volume | dtype, shape | brick before -> after | ratio before | after | gain | best peer | x peer before"
    " | after | encode CPU s before / after | decode CPU s before / after | tool after |"
)
print(HEAD)
print("|---|---|---|---:|---:|---:|---|---:|---:|---|---|---|")
for path in sys.argv[1:]:
    for r in csv.DictReader(open(path)):
        peer = f"{r['best_peer']} ({float(r['peer_ratio']):.3f})" if r["best_peer"] else "-"
        print(
            f"| {r['volume']} | {r['dtype']} {r['shape']} | {r['brick_before']} -> {r['brick_after']}"
            f" | {float(r['ratio_before']):.3f} | {float(r['ratio_after']):.3f} | {float(r['gain_pct']):+.1f} %"
            f" | {peer} | {r['x_peer_before'] or '-'} | {r['x_peer_after'] or '-'}"
            f" | {r['enc_cpu_before']} / {r['enc_cpu_after']} | {r['dec_cpu_before']} / {r['dec_cpu_after']}"
            f" | {r['tools_after']} |"
        )
