"""Before/after table of two bench_render_peers.py runs (volpack pre-integrated against VTK
matched, frame by frame in each run), session 37.

    python results/render/rend37/compare.py results/render/rend37/base/peers.csv results/render/rend37/after/peers.csv
"""

import csv
import sys
from pathlib import Path


def ratios(path):
    rows = list(csv.DictReader(open(path)))
    by = {(r["volume"], r["tf"], r["shading"], r["renderer"]): r for r in rows}
    out = {}
    for (v, tf, sh, ren), r in by.items():
        if ren != "volpack-preint":
            continue
        k = by[(v, tf, sh, "vtk-matched")]
        out[(Path(v).name.split(".")[0], tf, sh)] = (
            float(r["frame_s"]) / float(k["frame_s"]), float(r["frame_cpu_s"]) / float(k["frame_cpu_s"]),
            float(r["first_s"]) / float(k["first_s"]), float(r["psnr_db"]), float(k["psnr_db"]))
    return out


def main(base, after):
    b, a = ratios(base), ratios(after)
    f = lambda x: f"**{x:.2f}**" if x > 1 else f"{x:.2f}"  # noqa: E731
    print("| volume | TF | shading | frame x VTK wall / CPU, base | after | first image x VTK, base / after | "
          "PSNR volpack base / after / VTK (dB) |")
    print("|---|---|---|---:|---:|---:|---|")
    for key, (bw, bc, bf, bp, _) in b.items():
        aw, ac, af, ap, ak = a[key]
        vtk = f"**{ak:.1f}**" if ak > ap else f"{ak:.1f}"
        print(f"| {key[0]} | {key[1]} | {key[2]} | {f(bw)} / {f(bc)} | {f(aw)} / {f(ac)} | {f(bf)} / {f(af)} | "
              f"{bp:.1f} / {ap:.1f} / {vtk} |")
    n = len(a)
    print(f"\n{n} cases; after: wall <= 1x in {sum(v[0] <= 1 for v in a.values())} (base "
          f"{sum(v[0] <= 1 for v in b.values())}), CPU <= 1x in {sum(v[1] <= 1 for v in a.values())} (base "
          f"{sum(v[1] <= 1 for v in b.values())}); PSNR above VTK's in {sum(v[3] > v[4] for v in a.values())} "
          f"(base {sum(v[3] > v[4] for v in b.values())})")


if __name__ == "__main__":
    main(*sys.argv[1:3])
