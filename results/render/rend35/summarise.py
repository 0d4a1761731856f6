"""Markdown table of a bench_render_peers.py run: volpack pre-integrated against VTK matched.

    python results/render/rend35/summarise.py results/render/rend35/trial/peers.csv
"""

import csv
import sys
from pathlib import Path


def table(path):
    rows = list(csv.DictReader(open(path)))
    by = {(r["volume"], r["tf"], r["shading"], r["renderer"]): r for r in rows}
    out = ["| volume | dtype | TF | shading | frame, x VTK (wall / CPU) | first image, x VTK | "
           "frame ms volpack / VTK | PSNR volpack / VTK (dB) |",
           "|---|---|---|---|---:|---:|---:|---|"]
    worst = []
    for (v, tf, sh, ren), r in by.items():
        if ren != "volpack-preint":
            continue
        k = by[(v, tf, sh, "vtk-matched")]
        fw = float(r["frame_s"]) / float(k["frame_s"])
        fc = float(r["frame_cpu_s"]) / float(k["frame_cpu_s"])
        fi = float(r["first_s"]) / float(k["first_s"])
        pv, pk = float(r["psnr_db"]), float(k["psnr_db"])
        b = lambda x, bad: f"**{x:.2f}**" if bad else f"{x:.2f}"  # noqa: E731
        out.append(f"| {Path(v).name.split('.')[0]} | {r['dtype']} | {tf} | {sh} | {b(fw, fw > 1)} / {b(fc, fc > 1)} | "
                   f"{b(fi, fi > 1)} | {1e3 * float(r['frame_s']):.0f} / {1e3 * float(k['frame_s']):.0f} | "
                   f"{pv:.1f} / {'**' if pk > pv else ''}{pk:.1f}{'**' if pk > pv else ''} |")
        worst.append((fw, fc, v, tf, sh))
    worst.sort()
    n = len(worst)
    out.append("")
    out.append(f"{n} cases; frame wall <= 1x VTK in {sum(w[0] <= 1 for w in worst)}, CPU <= 1x in "
               f"{sum(w[1] <= 1 for w in worst)}; wall range {worst[0][0]:.2f}-{worst[-1][0]:.2f}x")
    return "\n".join(out)


if __name__ == "__main__":
    for p in sys.argv[1:]:
        print(table(p))
