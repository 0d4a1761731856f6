"""Markdown table of a bench_render_peers.py run (session 37, rend37b; copied for session 39, rend39): volpack
pre-integrated against VTK matched (frame wall / CPU, first image, PSNR) and against VTK
at its defaults (frame wall).

    python results/render/rend39/summarise.py results/render/rend39/heldout/peers.csv
"""

import csv
import sys
from pathlib import Path


def bold(x, bad):
    return f"**{x:.2f}**" if bad else f"{x:.2f}"


def table(path):
    rows = list(csv.DictReader(open(path)))
    by = {(r["volume"], r["tf"], r["shading"], r["renderer"]): r for r in rows}
    out = ["| volume | dtype | TF | shading | frame x VTK matched (wall / CPU) | first image x VTK | "
           "frame ms volpack / VTK | PSNR volpack / VTK matched (dB) | frame x VTK default | "
           "PSNR VTK default (dB) |",
           "|---|---|---|---|---:|---:|---:|---|---:|---:|"]
    stats = []
    for (v, tf, sh, ren), r in by.items():
        if ren != "volpack-preint":
            continue
        k = by[(v, tf, sh, "vtk-matched")]
        d = by.get((v, tf, sh, "vtk-default"))
        fw = float(r["frame_s"]) / float(k["frame_s"])
        fc = float(r["frame_cpu_s"]) / float(k["frame_cpu_s"])
        fi = float(r["first_s"]) / float(k["first_s"])
        pv, pk = float(r["psnr_db"]), float(k["psnr_db"])
        dw = float(r["frame_s"]) / float(d["frame_s"]) if d else float("nan")
        pd = float(d["psnr_db"]) if d else float("nan")
        pks = f"**{pk:.1f}**" if pk > pv else f"{pk:.1f}"
        out.append(f"| {Path(v).name.split('.')[0]} | {r['dtype']} | {tf} | {sh} | "
                   f"{bold(fw, fw > 1)} / {bold(fc, fc > 1)} | {bold(fi, fi > 1)} | "
                   f"{1e3 * float(r['frame_s']):.0f} / {1e3 * float(k['frame_s']):.0f} | "
                   f"{pv:.1f} / {pks} | {dw:.2f} | {pd:.1f} |")
        stats.append((fw, fc, fi, pv >= pk))
    n = len(stats)
    fws = sorted(s[0] for s in stats)
    out.append("")
    out.append(f"{n} cases; frame <= 1x VTK matched by wall in {sum(s[0] <= 1 for s in stats)}, "
               f"by CPU in {sum(s[1] <= 1 for s in stats)} (wall {fws[0]:.2f}-{fws[-1]:.2f}x); "
               f"within the 2x floor in {sum(s[0] <= 2 for s in stats)}; first image <= 1x in "
               f"{sum(s[2] <= 1 for s in stats)}; PSNR at or above VTK matched's in "
               f"{sum(s[3] for s in stats)}")
    return "\n".join(out)


if __name__ == "__main__":
    for p in sys.argv[1:]:
        print(table(p))
