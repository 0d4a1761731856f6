"""Print the markdown table of run.py's CSVs (the command line on every volume); a row
of a later CSV replaces the same volume's row of an earlier one (volumes run again).

    python results/cli/user32/summarise.py results/cli/user32/after.csv [MORE.csv ...]
"""

from __future__ import annotations

import csv
import sys


def cell(r, k, fmt="{}"):
    v = r.get(k) or ""
    return fmt.format(float(v)) if v and fmt != "{}" else v


def main(paths: list[str]) -> None:
    rows: dict[str, dict] = {}
    for path in paths:
        rows.update({r["volume"]: r for r in csv.DictReader(open(path))})
    print("| volume | dtype, shape | compress s | ratio | round trip | best peer (ratio) | x best peer |"
          " --rel-error 1e-3: ratio, x best peer (peer) |")
    print("|---|---|---:|---:|---|---|---:|---|")
    for r in rows.values():
        if r.get("compress_rc") not in ("0", None):
            err = r.get("error", "").replace("volpack: error: ", "")
            print(f"| {r['volume']} | {r['dtype']} {r['shape']} | - | - | refused: {err} | | | |")
            continue
        lossy = ""
        if r.get("lossy_ratio"):
            peer = r.get("lossy_best_peer") or "no peer takes it"
            x = cell(r, "lossy_x_best", "{:.3f}") or "-"
            lossy = f"{float(r['lossy_ratio']):.3f}, {x} ({peer})"
        elif r.get("lossy_error"):
            lossy = r["lossy_error"]
        print(
            f"| {r['volume']} | {r['dtype']} {r['shape']} | {r['compress_s']} | {float(r['ratio']):.3f} | "
            f"{r.get('roundtrip', '')} | {r.get('best_peer', '')} ({cell(r, 'best_peer_ratio', '{:.3f}')}) | "
            f"{cell(r, 'x_best', '{:.3f}')} | {lossy} |"
        )


if __name__ == "__main__":
    main(sys.argv[1:])
