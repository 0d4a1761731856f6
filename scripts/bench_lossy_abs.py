"""volpack against SPERR, SZ3 and zfp at absolute error bounds on one field (the cells an
issue quotes, e.g. the 64^3 float CT field at E = 0.001..0.3), every bound checked on
every voxel by ``bench_lossy.measure``.

    python scripts/bench_lossy_abs.py ct_skull_float --bounds 0.001,0.01,0.03,0.1,0.3 \\
        --out results/lossy/heldout4/abs_bounds.csv
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import bench_lossy
import datasets


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset")
    parser.add_argument("--bounds", default="0.001,0.01,0.03,0.1,0.3")
    parser.add_argument("--methods", default="volpack,sperr,sz3,sz3-best,zfp")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    a, _, _ = datasets.load(args.dataset)
    methods, _ = bench_lossy.build_methods(args.methods.split(","))
    rows = []
    for e in (float(b) for b in args.bounds.split(",")):
        for m in methods:
            encode = m.choose(a, e)[1] if m.choose else None
            r = bench_lossy.measure(m, a, a, e, args.repeat, encode=encode)
            rows.append({"dataset": args.dataset, "method": m.name, "E": e, **r})
            print(f"E={e:<8g} {m.name:10s} ratio {r['ratio']:8.2f}  max err {r['max_abs_err']:.4g}"
                  f" {'ok' if r['bound_ok'] else 'BOUND VIOLATED'}  decode {r['decode_MBps']:.0f}"
                  " MB/s", flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
