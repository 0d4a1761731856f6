"""Per case: volpack pre-integrated against VTK matched (frame wall and CPU ratios, PSNR),
before (first peers.csv) and after (second).

    python results/render/psnr25/compare.py <before>/peers.csv <after>/peers.csv
"""

import csv, sys
def load(p):
    return {(r["volume"], r["tf"], r["shading"], r["renderer"]): r for r in csv.DictReader(open(p))}
b, a = load(sys.argv[1]), load(sys.argv[2])
print("volume,tf,shading,before_x_vtk_wall,before_x_vtk_cpu,before_psnr,after_x_vtk_wall,after_x_vtk_cpu,after_psnr,vtk_psnr_before,vtk_psnr_after")
for k, r in a.items():
    if k[3] != "volpack-preint": continue
    v = a[k[:3] + ("vtk-matched",)]
    rb = b.get(k); vb = b.get(k[:3] + ("vtk-matched",))
    cpu = float(r["frame_cpu_s"]) / float(v["frame_cpu_s"])
    if rb:
        cb = float(rb["frame_cpu_s"]) / float(vb["frame_cpu_s"])
        print(f"{k[0]},{k[1]},{k[2]},{rb['vs_vtk_matched']},{cb:.2f},{rb['psnr_db']},{r['vs_vtk_matched']},{cpu:.2f},{r['psnr_db']},{vb['psnr_db']},{v['psnr_db']}")
    else:
        print(f"{k[0]},{k[1]},{k[2]},,,,{r['vs_vtk_matched']},{cpu:.2f},{r['psnr_db']},,{v['psnr_db']}")
