"""ldec36b's table and chart: the default lossy decode, base (1104b01) -> main (1adcc9f),
from bench_lossy_ab.py's ab.csv files and the payload kinds in stages_main_*.txt.

    python results/lossy/ldec36b/summarise.py [--chart results/lossy/ldec36b/ab.png]
"""

import argparse
import csv
from pathlib import Path

HERE = Path(__file__).resolve().parent
RUNS = [("ab_tune", ""), ("ab_heldout", " (held out)")]


def kinds() -> dict:
    out = {}
    for f in sorted(HERE.glob("stages_main_*.txt")):
        for line in f.read_text().splitlines():
            parts = line.split(",")
            if len(parts) > 4 and not line.startswith(("field", " ")):
                path, stages = ",".join(parts[3:-5]), parts[-1]
                out[parts[0], f"{float(parts[1]):g}"] = (path, stages)
    return out


def rows():
    for run, tag in RUNS:
        by = {}
        with (HERE / run / "ab.csv").open() as f:
            for r in csv.DictReader(f):
                by.setdefault((r["dataset"], r["rel_bound"]), {})[r["tree"]] = r
        for (name, rel), t in by.items():
            yield name + tag, rel, t["base"], t["main"]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--chart", type=Path)
    args = ap.parse_args()
    k = kinds()
    print("| field | bound | payload | ratio | same bits | ns/voxel base -> main | speed-up | x SZ3 base -> main "
          "| main's stages, ns/voxel |")
    print("|---|---|---|---:|---|---:|---:|---:|---|")
    table = []
    for name, rel, b, m in rows():
        nvox = eval(b["shape"].replace("x", "*"))
        mb = nvox * 4 / 1e6
        ns = [1e3 * mb / float(r["dec_MBps_volpack"]) / nvox * 1e6 for r in (b, m)]
        same = b["same_bytes"] == "True" and m["same_output"] == "True"
        kind, stages = k.get((name.split(" ")[0], rel), ("?", ""))
        print(f"| {name} | {rel} | {kind} | {float(m['ratio_volpack']):.2f} | {same} | "
              f"{ns[0]:.1f} -> {ns[1]:.1f} | {float(m['dec_speedup']):.3f} | "
              f"{float(b['dec_x_sz3']):.3f} -> {float(m['dec_x_sz3']):.3f} | {stages} |")
        table.append((f"{name.replace(' (held out)', '*')}\n{rel}", float(m["dec_speedup"]),
                      float(b["dec_x_sz3"]), float(m["dec_x_sz3"])))
    if args.chart:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.5))
        x = range(len(table))
        ax1.bar(x, [t[1] for t in table])
        ax1.axhline(1, color="k", lw=0.8)
        ax1.set_ylim(0.9, 1.1)
        ax1.set_title("decode speed-up main / base (same process pair)")
        ax2.bar([i - 0.2 for i in x], [t[2] for t in table], 0.4, label="base 1104b01")
        ax2.bar([i + 0.2 for i in x], [t[3] for t in table], 0.4, label="main 1adcc9f")
        ax2.axhline(0.5, color="r", lw=0.8, ls="--", label="issue 21 target 0.5")
        ax2.set_title("decode speed x SZ3 (one core)")
        ax2.legend(fontsize=8)
        for ax in (ax1, ax2):
            ax.set_xticks(list(x), [t[0] for t in table], fontsize=7, rotation=60)
        fig.suptitle("ldec36b: default lossy decode; * held out")
        fig.tight_layout()
        fig.savefig(args.chart, dpi=110)


if __name__ == "__main__":
    main()
