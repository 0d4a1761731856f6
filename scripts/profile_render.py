"""Where the ray caster's time goes on one real volume (issue 22, step 1).

Renders the volume at ``--size`` with a step of ``--step`` voxels on ``--workers``
threads, with a semi-transparent three-point transfer function (clear up to 10 % of the
range, 0.02 at 40 %, 0.15 at the top), orbit views 10 degrees apart, and times variants
that differ in one thing each:

* ``setup``: a 1 x 1 image (tables, the float copy, brick ranges, leap map, rays);
* ``post/none``: one trilinear sample and one 1-D table lookup per segment;
* ``preint/none``: the segment's back sample and a bilinear 2-D lookup;
* ``preint/phong``: plus the gradient at the midpoint;
* ``skip off``: without empty-space skipping (the samples it saves were invisible);
* ``ert off``: without early ray termination.

It prints samples per frame, samples per hit pixel, and CPU ns per sample (process CPU
time over all threads: the machine is shared, so wall time is noisy; best of
``--repeat``), and writes the rows to ``results/render/profile.csv``.

    python scripts/profile_render.py [mri_mni152] [--size 512] [--step 0.5] [--workers 2]
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))


def semi_tf(lo: float, hi: float):
    from volpack.render.transfer import TransferFunction

    r = hi - lo
    return TransferFunction(
        points=((lo + 0.1 * r, 0.0, 0.0, 0.0, 0.0), (lo + 0.4 * r, 0.9, 0.6, 0.5, 0.02),
                (hi, 1.0, 1.0, 1.0, 0.15)),
        name="semi",
    )  # fmt: skip


def main(argv=None) -> int:
    import datasets

    from volpack.render.camera import Camera
    from volpack.render.raycast import render

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset", nargs="?", default="mri_mni152")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--step", type=float, default=0.5)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--label", default="", help="a label for the rows (e.g. the commit)")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "render" / "profile.csv")
    args = ap.parse_args(argv)
    a, sp, _ = datasets.load(args.dataset)
    lo, hi = float(a.min()), float(a.max())
    tf = semi_tf(lo, hi)
    kw0 = dict(tf=tf, spacing=sp, step=args.step, workers=args.workers, value_range=(lo, hi))
    for cls, sh in (("post", "none"), ("preintegrated", "phong")):  # compile outside the timing
        render(a[:9, :9, :9], camera=Camera(size=(4, 4)), classification=cls, shading=sh, **kw0)
    variants = [
        ("setup", dict(classification="preintegrated", shading="phong"), 1),
        ("post/none", dict(classification="post", shading="none"), None),
        ("preint/none", dict(classification="preintegrated", shading="none"), None),
        ("preint/phong", dict(classification="preintegrated", shading="phong"), None),
        ("preint/phong skip off", dict(classification="preintegrated", shading="phong",
                                       skip_empty=False), None),  # fmt: skip
        ("preint/phong ert off", dict(classification="preintegrated", shading="phong",
                                      ert=1.0), None),  # fmt: skip
    ]
    rows = []
    print(f"{args.dataset} {a.shape} {a.dtype}, {args.size}^2, step {args.step}, "
          f"{args.workers} threads", flush=True)  # fmt: skip
    for name, kw, size in variants:
        best, st = np.inf, None
        for k in range(args.repeat):
            cam = Camera(azimuth=30 + 10 * k, size=(size or args.size,) * 2)
            t, c = time.perf_counter(), time.process_time()
            _, s = render(a, camera=cam, render_stats=True, **kw, **kw0)
            dt, dc = time.perf_counter() - t, time.process_time() - c
            if dc < best:
                best, wall, st = dc, dt, s
        ns = best / max(st.samples, 1) * 1e9
        row = {"label": args.label, "dataset": args.dataset, "variant": name, "wall_s": round(wall, 4),
               "cpu_s": round(best, 4),
               "samples": st.samples, "hit_pixels": st.hits,
               "samples_per_hit": round(st.samples / max(st.hits, 1), 1),
               "cpu_ns_per_sample": round(ns, 1)}  # fmt: skip
        rows.append(row)
        print(f"  {name:24s} {wall:7.3f} s wall {best:7.3f} s cpu  {st.samples / 1e6:7.2f} M samples  "
              f"{row['samples_per_hit']:6.1f} /hit px  {ns:6.1f} CPU ns/sample", flush=True)  # fmt: skip
    args.out.parent.mkdir(parents=True, exist_ok=True)
    new = not args.out.exists()
    with open(args.out, "a", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        if new:
            wr.writeheader()
        wr.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
