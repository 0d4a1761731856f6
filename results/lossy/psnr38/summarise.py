"""psnr38: the PSNR-target runs before/after as a markdown table, and a chart.

    python results/lossy/psnr38/summarise.py BASE.jsonl AFTER.jsonl [OUT.png]

Each file holds `results/lossy/psnr37/cli_psnr.py`'s lines (one `volpack compare --psnr P
--json` run each). Columns: bits per voxel, the PSNR compare measured on every voxel, the
search's whole-volume and sample tries, the encode's seconds (one CLI process a run, the
machine shared: times are rough), the codec kept; then after/before bits.
"""

import json
import sys


def load(path):
    out = {}
    for line in open(path):
        r = json.loads(line)
        out[(r["field"], r["target"])] = r
    return out


def cell(r):
    rep = r.get("report") or {}
    c = rep.get("compress") or {}
    s = c.get("search") or {}
    steps = s.get("steps", [])
    whole = sum(1 for x in steps if x.get("scope") == "all")
    warn = any("not reached" in w for w in r.get("stderr", []))
    return dict(
        bpv=rep.get("bpv"), psnr=rep.get("psnr"), tries=f"{whole}/{len(steps)}",
        sec=c.get("seconds"), codec=s.get("codec", c.get("mode", "?")), warn=warn,
    )  # fmt: skip


def main():
    base, after = load(sys.argv[1]), load(sys.argv[2])
    print("| field | target dB | before: bpv, PSNR, tries (whole/all), s | after: bpv, PSNR, "
          "tries, s | bpv after / before |")  # fmt: skip
    print("|---|---:|---|---|---:|")
    rows = []
    def fmt(c):
        w = " (warned)" if c["warn"] else ""
        return f"{c['bpv']:.4f}, {c['psnr']:.2f}{w}, {c['tries']}, {c['sec']:.1f} ({c['codec']})"

    for key in after:
        a = cell(after[key])
        if key not in base:  # not run before (yet)
            print(f"| {key[0]} | {key[1]:g} | - | {fmt(a)} | - |")
            continue
        b = cell(base[key])
        x = a["bpv"] / b["bpv"]
        rows.append((key, b, a, x))
        print(f"| {key[0]} | {key[1]:g} | {fmt(b)} | {fmt(a)} | {x:.3f} |")
    off = [(k, c["psnr"]) for k, _, c, _ in rows if abs(c["psnr"] - k[1]) > 0.5]
    print(f"\nafter: {sum(x < 0.999 for *_, x in rows)} fewer bits, "
          f"{sum(x > 1.001 for *_, x in rows)} more, of {len(rows)}; "
          f"more than 0.5 dB off the target: {off}")  # fmt: skip
    if len(sys.argv) > 3:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fields = sorted({k[0] for k, *_ in rows})
        fig, axes = plt.subplots(1, len(fields), figsize=(3 * len(fields), 3), squeeze=False)
        for ax, f in zip(axes[0], fields):
            for label, i, m in (("before", 1, "o"), ("after", 2, "x")):
                pts = sorted((r[i]["bpv"], r[i]["psnr"]) for r in rows if r[0][0] == f)
                ax.plot(*zip(*pts), m + "-", label=label)
            ax.set_title(f, fontsize=8)
            ax.set_xscale("log")
            ax.set_xlabel("bits per voxel", fontsize=7)
            ax.set_ylabel("PSNR dB", fontsize=7)
        axes[0][0].legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(sys.argv[3], dpi=90)


if __name__ == "__main__":
    main()
