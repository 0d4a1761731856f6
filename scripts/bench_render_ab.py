"""A/B of two source trees on one renderer case, in alternating processes, each beside VTK.

Each round starts one process per tree (``PYTHONPATH`` = the tree), in turn: it loads
the volume, compiles volpack's kernels on a coarse copy, prepares the volume and then
renders ``--frames`` orbit views (10 degrees apart, the peers benchmark's scene: the
``--tf`` TF, 512x512, step 0.5) with volpack pre-integrated and VTK matched taking turns,
and prints the best and median CPU seconds of each (process time over all threads:
the machine is shared, so wall time is noisy; wall seconds are printed too) and the
segments a volpack frame took. ``--cases tf:shading ...`` runs several cases, one
process a case and tree, the trees alternating case by case.
The first view's volpack image is saved per tree, and the largest difference and PSNR
between the trees' images are printed at the end. Rows go to ``--out`` (CSV).

    python scripts/bench_render_ab.py --trees /tmp/main_src . --volumes ct_head \\
        [--tf semi] [--shading none] [--workers 1] [--rounds 3] [--frames 5]
"""

from __future__ import annotations

import argparse
import csv
import itertools
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def child(args) -> None:
    """One process: volpack and VTK frames on one case; prints one JSON line."""
    sys.path.insert(0, str(ROOT / "scripts"))
    import bench_render_peers as peers
    import datasets

    from volpack.render.camera import Camera
    from volpack.render.prepared import prepare_volume
    from volpack.render.raycast import render
    from volpack.render.transfer import TransferFunction

    vol, spacing, _ = datasets.load(args.volume)
    spacing = tuple(float(s) for s in spacing)
    points = peers.tf_points(args.tf, *peers.tf_base(vol))
    tf = TransferFunction(points=points)
    shade = args.shading != "none"
    k = max(1, max(vol.shape) // 16)  # compile outside the timings
    render(vol[::k, ::k, ::k], spacing=tuple(s * k for s in spacing), tf=tf,
           shading=args.shading, camera=Camera(size=(16, 16)), workers=args.workers)  # fmt: skip
    prep = prepare_volume(vol, spacing)
    vtk = peers.Vtk(vol, spacing, points, shade, args.workers, args.size,
                    args.step * min(spacing)) if args.vtk else None  # fmt: skip
    vp, vt, vpw, vtw, samples = [], [], [], [], 0
    for j in range(args.frames + 1):
        az = 30.0 + 10.0 * j
        cam = Camera(azimuth=az, elevation=peers.ELEVATION, size=(args.size, args.size))
        t, c = time.perf_counter(), time.process_time()
        img, st = render(prep, tf=tf, camera=cam, step=args.step, shading=args.shading,
                         workers=args.workers, render_stats=True)  # fmt: skip
        dt, dc = time.perf_counter() - t, time.process_time() - c
        if j == 0:
            np.save(args.image, img)
            samples = st.samples
        else:
            vp.append(dc)
            vpw.append(dt)
        if vtk is not None:
            tv, dv = vtk.frame(az)
            if j:
                vt.append(dv)
                vtw.append(tv)
    res = {"volpack_best": min(vp), "volpack_median": float(np.median(vp)), "samples": samples,
           "volpack_wall_median": float(np.median(vpw))}  # fmt: skip
    if vt:
        res.update(vtk_best=min(vt), vtk_median=float(np.median(vt)),
                   vtk_wall_median=float(np.median(vtw)))  # fmt: skip
    print(json.dumps(res), flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trees", nargs="+", type=Path, default=[ROOT])
    ap.add_argument("--volumes", nargs="+", default=["ct_head"])
    ap.add_argument("--tf", default="semi", choices=["semi", "opaque"])
    ap.add_argument("--shading", default="none")
    ap.add_argument("--cases", nargs="+", default=None,
                    help="tf:shading pairs (e.g. opaque:phong), instead of --tf/--shading")  # fmt: skip
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--step", type=float, default=0.5)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--no-vtk", dest="vtk", action="store_false")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--volume", help=argparse.SUPPRESS)
    ap.add_argument("--image", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(args)
        return 0
    rows = []
    tmp = Path(os.environ.get("TMPDIR", "/tmp")) / f"render_ab_{os.getpid()}"
    tmp.mkdir(parents=True, exist_ok=True)
    cases = [c.split(":") for c in args.cases] if args.cases else [(args.tf, args.shading)]
    for name, (tfk, shading) in itertools.product(args.volumes, cases):
        for rnd in range(args.rounds):
            for t, tree in enumerate(args.trees):
                image = tmp / f"{name}_{tfk}_{shading}_{t}.npy"
                cmd = [sys.executable, str(Path(__file__).resolve()), "--child", "--volume", name,
                       "--image", str(image), "--tf", tfk, "--shading", shading,
                       "--workers", str(args.workers), "--size", str(args.size),
                       "--step", str(args.step), "--frames", str(args.frames)]  # fmt: skip
                if not args.vtk:
                    cmd.append("--no-vtk")
                env = dict(os.environ, PYTHONPATH=str(tree.resolve()))
                load = os.getloadavg()[0]
                out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
                res = json.loads(out.stdout.strip().splitlines()[-1])
                row = {"volume": name, "tf": tfk, "shading": shading,
                       "workers": args.workers, "round": rnd, "tree": str(tree),
                       "load": round(load, 1), **{k: round(v, 4) if isinstance(v, float) else v
                                                  for k, v in res.items()}}  # fmt: skip
                if "vtk_best" in res:
                    row["ratio_best"] = round(res["volpack_best"] / res["vtk_best"], 3)
                    row["ratio_median"] = round(res["volpack_median"] / res["vtk_median"], 3)
                    row["ratio_wall_median"] = round(
                        res["volpack_wall_median"] / res["vtk_wall_median"], 3)
                rows.append(row)
                print(json.dumps(row), flush=True)
        imgs = [np.load(tmp / f"{name}_{tfk}_{shading}_{t}.npy") for t in range(len(args.trees))]
        for t in range(1, len(imgs)):
            d = np.abs(imgs[t].astype(np.float64) - imgs[0])
            mse = float(np.mean(d[..., :3] ** 2))
            psnr = 99.0 if mse == 0 else 10 * math.log10(1.0 / mse)
            print(f"{name} {tfk} {shading}: tree {t} against tree 0: max abs {d.max():.3g}, "
                  f"PSNR {psnr:.1f} dB")  # fmt: skip
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        keys = list(dict.fromkeys(k for r in rows for k in r))
        with open(args.out, "w", newline="") as f:
            wr = csv.DictWriter(f, fieldnames=keys)
            wr.writeheader()
            wr.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
