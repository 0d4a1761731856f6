"""Wavelet comparison in the manner of the method's Table 2.9: each filter at the same
quality settings, ratio and PSNR side by side.

Integer lifting filters (Haar, 5/3, 2/6, 9/7-M) go through volpack's ``coef`` codec; the
float Daubechies-4, Coiflet-6 and CDF 9/7 through PyWavelets (``pywt`` codec). All use the
arithmetic coder; the float filters' coefficients are coded line by line over PyWavelets'
coefficient array, without the subband contexts the lifting filters get.

    python scripts/bench_wavelets.py [--datasets ct_head,mri_ch2] [--out results/wavelets]
"""

from __future__ import annotations

import argparse
import csv
import io
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

WAVELETS = ["haar", "53", "26", "97m", "d4", "c6", "cdf97"]
QUALITIES = [255, 63, 15]


def main(argv: list[str] | None = None) -> int:
    import datasets
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from volpack import api

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", default="ct_head,mri_ch2")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "wavelets")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in args.datasets.split(","):
        a = datasets.load(name)[0]
        for w in WAVELETS:
            for q in QUALITIES:
                t = time.perf_counter()
                st = api.compress(a, io.BytesIO(), quality=q, wavelet=w, workers=2)
                rows.append(
                    {
                        "dataset": name,
                        "wavelet": w,
                        "quality": q,
                        "ratio": round(st["ratio"], 3),
                        "psnr": round(st["psnr"], 3),
                        "max_error": st["max_error"],
                        "seconds": round(time.perf_counter() - t, 3),
                    }
                )
                print(rows[-1], flush=True)
    with open(args.out / "wavelets.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    names = sorted({r["dataset"] for r in rows}, key=args.datasets.split(",").index)
    fig, axes = plt.subplots(1, len(names), figsize=(6 * len(names), 4.5), squeeze=False)
    for ax, name in zip(axes[0], names):
        for w in WAVELETS:
            pts = [
                (r["ratio"], r["psnr"]) for r in rows if r["dataset"] == name and r["wavelet"] == w
            ]
            ax.plot(*zip(*pts), "o-" if w in WAVELETS[:4] else "s--", label=w)
        ax.set_xscale("log")
        ax.set_xlabel("compression ratio")
        ax.set_ylabel("PSNR (dB)")
        ax.set_title(f"{name}: quality {', '.join(map(str, QUALITIES))}")
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(args.out / "wavelets.png", dpi=110)
    lines = ["# Wavelets at equal quality (ratio / PSNR dB)", ""]
    for name in names:
        lines += [
            f"## {name}",
            "",
            "| wavelet | " + " | ".join(f"quality {q}" for q in QUALITIES) + " |",
        ]
        lines.append("|---|" + "---:|" * len(QUALITIES))
        for w in WAVELETS:
            cells = [
                f"{r['ratio']:.2f} / {r['psnr']:.2f}"
                for q in QUALITIES
                for r in rows
                if r["dataset"] == name and r["wavelet"] == w and r["quality"] == q
            ]
            lines.append(f"| {w} | " + " | ".join(cells) + " |")
        lines.append("")
    (args.out / "table.md").write_text("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
