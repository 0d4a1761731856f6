"""ldec36's tables (markdown) and chart from its CSVs: the A/B (ab_tune.csv, ab_heldout.csv,
pfd32's ab.py), the profiles (profile_base.csv, profile_branch.csv; pfd32's profile.py), the decisions a residual
(count_base.csv) and the fewer-decisions measurement (fewer.csv).

    python results/lossless/ldec36/summarise.py [--chart results/lossless/ldec36/ab.png]
"""

import argparse
import csv
from pathlib import Path

HERE = Path(__file__).resolve().parent


def rows(name):
    with (HERE / name).open() as f:
        return list(csv.DictReader(f))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--chart", type=Path)
    args = ap.parse_args()
    ab = [(r, "") for r in rows("ab_tune.csv")] + [(r, " (held out)") for r in rows("ab_heldout.csv")]
    print("| item | same bits | predictfit ns/voxel base -> branch | predictfit speedup | whole decode"
          " speedup | whole MB/s base -> branch | x JPEG-LS base -> branch |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for r, tag in ab:
        print(f"| {r['item']}{tag} | {r['same']} | {r['pf_base_ns']} -> {r['pf_branch_ns']} | {r['pf_speedup']} "
              f"| {r['whole_speedup']} | {r['whole_base_MBs']} -> {r['whole_branch_MBs']} "
              f"| {r['x_peer_base']} -> {r['x_peer_branch']} |")
    print("\n| item | full | predict | of which blend | entropy | loop |\n|---|---:|---:|---:|---:|---:|")
    for r, b in zip(rows("profile_base.csv"), rows("profile_branch.csv")):
        print(f"| {r['item']} | " + " | ".join(f"{r[k]} -> {b[k]}" for k in
                                               ("full_ns", "predict_ns", "blend_ns", "entropy_ns", "loop_ns")) + " |")
    print("\n| item | residual | share | decisions | of which mixed | raw bits |\n|---|---|---:|---:|---:|---:|")
    for r in rows("count_base.csv"):
        print(f"| {r['item']} | {r['class']} | {r['share']} | {r['decisions']} | {r['mixed']} | {r['raw_bits']} |")
    print("\n| item | bits a residual today | len1 (ratio) | zl1 (ratio) | decisions today -> len1 / zl1 "
          "| model search len1 / zl1 ns |\n|---|---:|---:|---:|---:|---:|")
    for r in rows("fewer.csv"):
        print(f"| {r['item']} | {r['bits_today']} | {r['bits_len1']} ({r['ratio_len1']}x) "
              f"| {r['bits_zl1']} ({r['ratio_zl1']}x) | {r['decisions_today']} -> {r['decisions_len1']} / "
              f"{r['decisions_zl1']} | {r['search_len1_ns']} / {r['search_zl1_ns']} |")
    if args.chart:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        names = [r["item"] + ("*" if tag else "") for r, tag in ab]
        fig, ax = plt.subplots(1, 2, figsize=(11, 4))
        x = range(len(ab))
        ax[0].bar([i - 0.2 for i in x], [float(r["pf_base_ns"]) for r, _ in ab], 0.4, label="base 1104b01")
        ax[0].bar([i + 0.2 for i in x], [float(r["pf_branch_ns"]) for r, _ in ab], 0.4, label="ldec36")
        ax[0].set_ylabel("predictfit decode, ns per voxel (best of 5, CPU)")
        ax[1].bar([i - 0.2 for i in x], [float(r["x_peer_base"]) for r, _ in ab], 0.4, label="base 1104b01")
        ax[1].bar([i + 0.2 for i in x], [float(r["x_peer_branch"]) for r, _ in ab], 0.4, label="ldec36")
        ax[1].axhline(1.0, color="k", lw=0.8)
        ax[1].set_ylabel("whole decode speed / JPEG-LS's (1 = level)")
        for a in ax:
            a.set_xticks(list(x))
            a.set_xticklabels(names, rotation=30, ha="right", fontsize=8)
            a.legend(fontsize=8)
        fig.suptitle("ldec36: the default lossless decoder, same bits (* held out)")
        fig.tight_layout()
        fig.savefig(args.chart, dpi=110)


if __name__ == "__main__":
    main()
