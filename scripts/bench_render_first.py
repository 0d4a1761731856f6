"""The first image against VTK's first, repeated: what a user waits for before the first
frame of a volume, with everything built from scratch each time.

``scripts/bench_render_peers.py`` times one first image per renderer and case; on a
shared machine one sample is noisy. Here, in one process, for each volume x transfer
function x shading of that benchmark (the same scenes, 512x512, 2 threads), VTK
matched (``vtkFixedPointVolumeRayCastMapper``, a new mapper: its gradients and tables)
and volpack pre-integrated (``prepare_volume``, empty-space maps, quantised normals
when shaded, tables; a new PreparedVolume and no kept tables) take turns ``--reps``
times; wall and process CPU seconds, the median of each. volpack's kernels are compiled
first, as in the peers benchmark (VTK's code is compiled already). Writes
``first.csv`` under ``--out``.

    python scripts/bench_render_first.py [--reps 5] [--out results/render]
"""

from __future__ import annotations

import csv
import statistics
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))

from bench_render_peers import Volpack, Vtk, load_warm, scene_args, tf_base, tf_points  # noqa: E402


def main(argv=None) -> int:
    ap = scene_args(__doc__)
    ap.add_argument("--reps", type=int, default=5)
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in args.volumes:
        vol, spacing = load_warm(name, args.workers)
        for tfk in ("semi", "opaque"):
            points = tf_points(tfk, *tf_base(vol))
            for shade in (False, True):
                t = {"vtk": [], "volpack": []}
                for _ in range(args.reps):  # turn by turn
                    v = Vtk(vol, spacing, points, shade, args.workers, args.size,
                            args.step * min(spacing))  # fmt: skip
                    t["vtk"].append(v.frame(30.0))
                    p = Volpack(vol, spacing, points, shade, args.workers, args.size, args.step,
                                "preintegrated")  # fmt: skip
                    t["volpack"].append(p.frame(30.0))
                    del v, p
                row = {"volume": name, "tf": tfk, "shading": "phong" if shade else "none"}
                for k, ts in t.items():
                    row[f"{k}_first_s"] = round(statistics.median(w for w, _ in ts), 4)
                    row[f"{k}_first_cpu_s"] = round(statistics.median(c for _, c in ts), 4)
                row["ratio_wall"] = round(row["volpack_first_s"] / row["vtk_first_s"], 2)
                row["ratio_cpu"] = round(row["volpack_first_cpu_s"] / row["vtk_first_cpu_s"], 2)
                rows.append(row)
                print("  ".join(f"{k} {v}" for k, v in row.items()), flush=True)
    with open(args.out / "first.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    print(f"wrote {args.out / 'first.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
