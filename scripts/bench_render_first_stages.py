"""What volpack's first image spends beyond a later frame, stage by stage.

For each volume and each of the peers benchmark's cases (:mod:`bench_render_peers`:
``semi`` / ``opaque`` transfer function x unshaded / Phong, 512x512, step 0.5), times
each piece of work the first image does and later frames of an orbit reuse, called
as :func:`volpack.render.raycast.render` calls it: ``prepare_volume`` (the sampled
array, non-finite mask, value range), the per-brick value ranges, the classification
tables (the pre-integrated table, its half-step table for refinement, the
nearest-entry test, clear bounds and visible entries), the empty bricks, the leap map,
the quantised normals of the chunks the visible bricks reach (Phong only), the rays;
then a later frame of the prepared volume, for scale. Kernels are compiled first
(``bench_render_peers.warm_up``), so no stage times the compiler. CPU seconds of one
thread (``--workers``, default 1), best of ``--repeat``: the machine is shared.
Writes ``first_stages.csv`` under ``--out``.

    python scripts/bench_render_first_stages.py [--volumes ct_head ...] [--out DIR]
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


def best(fn, repeat: int) -> float:
    """The least process CPU time of ``repeat`` calls of ``fn``."""
    out = float("inf")
    for _ in range(repeat):
        c = time.process_time()
        fn()
        out = min(out, time.process_time() - c)
    return out


def stages(name, vol, spacing, workers, repeat):
    """Rows ``(volume, tf, shading, stage, cpu_s)`` for one volume."""
    from bench_render_peers import ELEVATION, tf_base, tf_points

    from volpack.render import raycast as rc
    from volpack.render.camera import Camera
    from volpack.render.normals import NormalCodes
    from volpack.render.prepared import prepare_volume
    from volpack.render.transfer import TransferFunction

    rows = []
    prep = prepare_volume(vol, spacing)
    lo, hi = prep.finite_range
    n = rc.TABLE_SIZE
    scale = (n - 1) / (hi - lo)
    brick = rc.brick_size(prep.shape)
    nb = tuple(max(1, -(-s // brick)) for s in prep.shape)
    cam = Camera(azimuth=30.0, elevation=ELEVATION, size=(512, 512))

    def ranges():
        rc.brick_ranges(prep.data, brick, np.empty(nb, np.float32), np.empty(nb, np.float32),
                        workers)  # fmt: skip

    common = {"prepare_volume": lambda: prepare_volume(vol, spacing), "brick ranges": ranges,
              "rays": lambda: cam.rays(prep.shape, spacing)}  # fmt: skip
    shared = {k: best(f, repeat) for k, f in common.items()}
    mins, maxs = prep.brick_ranges(None, brick, lambda *a: rc.brick_ranges(*a, workers))
    for tfk in ("semi", "opaque"):
        tf = TransferFunction(points=tf_points(tfk, *tf_base(vol)))
        base = rc.transfer_table(tf, lo, hi, n)

        def tables():
            t = rc._Tables(base, 0.5, True, False, "fast")
            t.sub(2), t.nearest(), t.clear(False), t.shown(False)
            return t

        t = tables()
        none = np.zeros((1, 1, 4), np.float32)

        def empty_bricks():
            return rc._empty_bricks(prep.data, prep.shape, None, 2, True, t.post, t.pre2d,
                                    none, False, lo, scale, True, (mins, maxs), brick)  # fmt: skip

        empty = empty_bricks()

        def leap():
            rc._leap_kernel(np.ascontiguousarray(empty), np.zeros(empty.shape, np.int32))

        def codes():
            NormalCodes(prep.data, spacing).ensure(~empty, brick, 0.25, workers)

        own = {"tables": best(tables, repeat), "empty bricks": best(empty_bricks, repeat),
               "leap map": best(leap, repeat)}  # fmt: skip
        for shade in ("none", "phong"):
            extra = dict(shared, **own)
            if shade == "phong":
                extra["normal codes"] = best(codes, repeat)

            def frame(sh=shade):
                rc.render(prep, tf=tf, camera=cam, step=0.5, shading=sh, workers=workers)

            frame()
            later = best(frame, repeat)
            for k, v in extra.items():
                rows.append((name, tfk, shade, k, round(v, 4)))
            rows.append((name, tfk, shade, "first-image extra, sum", round(sum(extra.values()), 4)))
            rows.append((name, tfk, shade, "later frame", round(later, 4)))
            print(f"  {name} {tfk} {shade}: extra {sum(extra.values()):.3f} CPU s "
                  f"({', '.join(f'{k} {v:.3f}' for k, v in extra.items())}), "
                  f"later frame {later:.3f}", flush=True)  # fmt: skip
    return rows


def main(argv=None) -> int:
    from bench_render_peers import VOLUMES, load_warm

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--volumes", nargs="+", default=list(VOLUMES))
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "render")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in args.volumes:
        vol, spacing = load_warm(name, args.workers)
        print(f"{name} {vol.shape} {vol.dtype}", flush=True)
        rows += stages(name, vol, spacing, args.workers, args.repeat)
    with open(args.out / "first_stages.csv", "w", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["volume", "tf", "shading", "stage", "cpu_s"])
        wr.writerows(rows)
    print(f"wrote {args.out / 'first_stages.csv'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
