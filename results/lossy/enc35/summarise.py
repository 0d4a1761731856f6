"""Markdown table of the encode A/B (main against enc35) from tune/ab.csv and
heldout/ab.csv, geometric means per set, and enc_speedup.png.

    python results/lossy/enc35/summarise.py
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

HERE = Path(__file__).resolve().parent
SETS = {"tune": "tuning", "heldout": "HELD OUT"}


def rows(sub):
    path = HERE / sub / "ab.csv"
    if not path.exists():
        return []
    with path.open() as f:
        return [r for r in csv.DictReader(f) if r["tree"] == "branch"]


def main():
    print("| set | field | bound | ratio | enc MB/s main | enc MB/s enc35 | enc speed-up | "
          "same bytes |")
    print("|---|---|---:|---:|---:|---:|---:|:---:|")
    bars = []
    for sub, label in SETS.items():
        rs = rows(sub)
        for r in rs:
            main_mbps = float(r["enc_MBps_volpack"]) / float(r["enc_speedup"])
            same = r["same_bytes"] == "True" and r["same_output"] == "True"
            print(f"| {label} | {r['dataset']} | {r['rel_bound']} | "
                  f"{float(r['ratio_volpack']):.2f} | {main_mbps:.2f} | "
                  f"{float(r['enc_MBps_volpack']):.2f} | {float(r['enc_speedup']):.3f} | "
                  f"{'yes' if same else 'NO'} |")
            bars.append((f"{r['dataset']}@{r['rel_bound']}", float(r["enc_speedup"]), sub))
        if rs:
            g = math.exp(sum(math.log(float(r["enc_speedup"])) for r in rs) / len(rs))
            ok = all(r["same_bytes"] == "True" for r in rs)
            print(f"| {label} | **geometric mean** ({len(rs)} cells) | | | | | **{g:.3f}** | "
                  f"{'all' if ok else 'NOT all'} |")
    if bars:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(9, 4))
        ax.bar(range(len(bars)), [b[1] for b in bars],
               color=["C0" if b[2] == "tune" else "C1" for b in bars])
        ax.axhline(1.0, color="k", lw=0.8)
        ax.set_xticks(range(len(bars)), [b[0] for b in bars], rotation=60, ha="right",
                      fontsize=7)
        ax.set_ylabel("encode CPU time main / enc35")
        ax.set_title("default lossy encode, enc35 over main (blue: tuning, orange: held out)")
        fig.tight_layout()
        fig.savefig(HERE / "enc_speedup.png", dpi=110)


if __name__ == "__main__":
    main()
