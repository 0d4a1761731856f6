"""Tables and a chart of the psnr37 runs: volpack's PSNR mode (CLI) against TTHRESH at the
same targets and zfp interpolated, bits per voxel at equal PSNR.

    python results/lossy/psnr37/summarise.py BENCH_DIR CLI.jsonl OUT_PREFIX

BENCH_DIR/lossy.csv: scripts/bench_lossy.py's rows (volpack bounded, zfp, tthresh).
CLI.jsonl: results/lossy/psnr37/cli_psnr.py's runs. Writes OUT_PREFIX.md (the table),
OUT_PREFIX.png (PSNR against bits per voxel, a panel per field) and OUT_PREFIX.csv (the
bench's rows plus the CLI runs as method ``volpack-psnr``, for ``bench_lossy.py
--from-csv``, whose equal_psnr.md then reads both volpack curves).

A peer's bits at volpack's PSNR: its curve (log bits, linear in PSNR) interpolated at the
PSNR volpack reached; "-" where that PSNR is outside the peer's measured points.
x = peer bits / volpack bits (above 1: volpack ahead). A target counts as met when the
decoded PSNR is within 0.5 dB of it (what the search aims at).
"""

from __future__ import annotations

import csv
import json
import math
import sys
from pathlib import Path

import numpy as np


def curve(rows, field, method):
    pts = sorted((float(r["psnr_db"]), float(r["bits_per_voxel"])) for r in rows
                 if r["dataset"] == field and r["method"] == method
                 and math.isfinite(float(r["psnr_db"])))  # fmt: skip
    return pts


def at(pts, p):
    if len(pts) < 2 or not pts[0][0] <= p <= pts[-1][0]:
        return None
    ps = np.array([q for q, _ in pts])
    return float(np.exp(np.interp(p, ps, np.log([b for _, b in pts]))))


def main() -> None:
    bench, cli, out = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
    rows = list(csv.DictReader(open(bench / "lossy.csv")))
    runs = [json.loads(line) for line in open(cli)]
    lines = [
        "| field | target dB | volpack bpv (PSNR reached, codec) | TTHRESH bpv at the target "
        "(its PSNR) | TTHRESH at volpack's PSNR, x | zfp at volpack's PSNR, x |",
        "|---|---:|---|---|---:|---:|",
    ]
    extra, xs, misses, bad = [], {"tthresh": [], "zfp": []}, [], []
    for run in runs:
        f, p, rep = run["field"], run["target"], run["report"]
        if run["rc"] != 0 or not rep:
            bad.append(f"{f} {p:g}: rc {run['rc']} {run['stderr']}")
            lines.append(f"| {f} | {p:g} | FAILED rc {run['rc']} | | | |")
            continue
        bpv, got = 8.0 * rep["file_nbytes"] / math.prod(rep["shape"]), rep["psnr"]
        codec = (rep["compress"].get("codec") or {}).get("id", rep["compress"].get("mode"))
        reached = rep["compress"].get("psnr")
        if abs(got - p) > 0.5:
            misses.append(f"{f} at {p:g} dB: compare measured {got:.2f} dB"
                          + (f" (the encoder's search: {reached:.2f})" if reached else ""))  # fmt: skip
        if got > 300 and reached is not None:  # base code: compare's PSNR of a fill field
            got = reached  # took the fill (1e35) as its peak; the search's is over the rest
        tt = [r for r in rows if r["dataset"] == f and r["method"] == "tthresh"
              and r["setting"] == f"PSNR={p:g}"]  # fmt: skip
        ttxt = f"{float(tt[0]['bits_per_voxel']):.3f} ({float(tt[0]['psnr_db']):.1f})" if tt else "crashed"
        cells = []
        for m in ("tthresh", "zfp"):
            b = at(curve(rows, f, m), got)
            if b is None:
                cells.append("-")
            else:
                xs[m].append(b / bpv)
                cells.append(f"{b:.3f}, **{b / bpv:.2f}**" if b < bpv else f"{b:.3f}, {b / bpv:.2f}")
        lines.append(f"| {f} | {p:g} | {bpv:.3f} ({got:.2f}, {codec}) | {ttxt} | {cells[0]} | {cells[1]} |")
        r0 = next(r for r in rows if r["dataset"] == f)
        extra.append({**{k: r0[k] for k in ("dataset", "kind", "dtype", "shape", "value_range")},
                      "method": "volpack-psnr", "setting": f"PSNR={p:g}", "bound": "",
                      "input_dtype": rep["dtype"], "compressed_bytes": rep["file_nbytes"],
                      "ratio": rep["ratio"], "bits_per_voxel": bpv, "psnr_db": got,
                      "rmse": rep["rmse"], "max_abs_err": rep["max_error"], "bound_ok": "",
                      "excess": "", "config": codec,
                      "encode_MBps": rep["raw_nbytes"] / rep["enc_seconds"] / 1e6,
                      "decode_MBps": rep["raw_nbytes"] / rep["dec_seconds"] / 1e6})  # fmt: skip
    lines.append("")
    for m, v in xs.items():
        if v:
            lines.append(f"{m}: {sum(x > 1 for x in v)} of {len(v)} points with volpack ahead "
                         f"(x from {min(v):.2f} to {max(v):.2f}).")  # fmt: skip
    lines.append(f"Targets missed by more than 0.5 dB: {len(misses)}" + "".join(f"\n- {m}" for m in misses))
    lines.append(f"Runs failed: {len(bad)}" + "".join(f"\n- {m}" for m in bad))
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    with open(out.with_suffix(".csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows + extra)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fields = list(dict.fromkeys(r["dataset"] for r in rows))
    fig, axes = plt.subplots(math.ceil(len(fields) / 3), 3, figsize=(15, 3.6 * math.ceil(len(fields) / 3)), squeeze=False)
    style = {"volpack": ("tab:red", "o"), "volpack-psnr": ("darkred", "P"), "zfp": ("tab:blue", "^"),
             "tthresh": ("tab:cyan", "*")}  # fmt: skip
    for ax, f in zip(axes.flat, fields):
        for m, (c, mk) in style.items():
            pts = curve(rows + extra, f, m)
            if pts:
                ax.plot([b for _, b in pts], [q for q, _ in pts], marker=mk, color=c, label=m, lw=1.2)
        ax.set(xscale="log", title=f, xlabel="bits per voxel", ylabel="PSNR dB")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(fields):]:
        ax.set_visible(False)
    fig.tight_layout()
    fig.savefig(out.with_suffix(".png"), dpi=90)


if __name__ == "__main__":
    main()
