"""Walkthrough speed: `volpack walk` of an octree of a real MRI, per frame, against the
plain renderer on the whole volume.

Builds (once, cached under --work) a lossless octree (16^3 nodes) of the 8-bit MRI
``mri_mni152`` (189 x 233 x 197), then flies an orbit of --frames views around it at
512x512 with what `volpack walk` does: the view-dependent selection within --budget
nodes, the node atlas kept across frames (:class:`volpack.render.lod.NodeAtlas`) and
the ray caster, pre-integrated with Phong shading, the auto transfer function. Per
frame: wall and CPU seconds (the machine is shared: CPU seconds of this process, both
threads, are the steadier figure), the split into selection, decoding/assembly and
rendering, and for the same view the plain renderer on the whole decoded volume (a
PreparedVolume kept across frames), so ``ratio`` is walk / plain in CPU seconds.

With ``--paged`` the same frame is also drawn by a second atlas kept on the paged
sampler (``resident_budget=0``), timed alike (``paged_*``), and the PSNR of each walk
image against the plain one and of the two walk images against each other is
recorded (``psnr_*``, dB over RGB). Writes results/render/walk.csv. Runs against a
tree older than NodeAtlas as well (it then keeps the older dict of bricks), to
measure before/after.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv=None) -> int:
    import datasets

    from volpack.octree import Octree, build
    from volpack.render import lod, transfer
    from volpack.render.camera import Camera
    from volpack.render.prepared import prepare_volume
    from volpack.render.raycast import render

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--volume", default="mri_mni152")
    ap.add_argument("--work", type=Path, default=Path(tempfile.gettempdir()) / "volpack-bench",
                    help="where the octree is built once")  # fmt: skip
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "render" / "walk.csv")
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--budget", type=int, default=1024)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--shading", default="phong")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--no-plain", action="store_true", help="skip the whole-volume renders")
    ap.add_argument("--paged", action="store_true",
                    help="also walk with the paged sampler (resident volume off)")  # fmt: skip
    ap.add_argument("--resident-budget", type=int, default=None,
                    help="bytes of the resident volume (0: paged only; default the library's)")  # fmt: skip
    args = ap.parse_args(argv)

    vol, spacing, _ = datasets.load(args.volume)
    args.work.mkdir(parents=True, exist_ok=True)
    path = args.work / f"{args.volume}_octree16.vpk"
    if not path.exists():
        build(vol, str(path), block=16, workers=args.workers)
    rows = []
    with Octree(str(path), cache_bytes=1 << 30) as tree:
        lo, hi = lod.tree_range(tree)
        tf = transfer.load_tf("auto", lo, hi, dtype=tree.dtype)
        kw = dict(tf=tf, value_range=(lo, hi), step=0.5, classification="preintegrated",
                  shading=args.shading, workers=args.workers)  # fmt: skip
        shaded = args.shading != "none"
        if hasattr(lod, "NodeAtlas"):
            rb = {} if args.resident_budget is None else {"resident_budget": args.resident_budget}
            keep = {"atlas": lod.NodeAtlas(tree, gradients=shaded, **rb)}
        else:  # an older tree: a dict of assembled bricks
            keep = {"bricks": {}}
        paged = lod.NodeAtlas(tree, gradients=shaded, resident_budget=0) if args.paged else None
        full = None if args.no_plain else prepare_volume(vol, tree.spacing)
        for k in range(args.frames):
            cam = Camera(azimuth=30.0 + 360.0 * k / args.frames, elevation=20.0,
                         size=(args.size, args.size))  # fmt: skip
            w0, c0 = time.perf_counter(), time.process_time()
            img, st = lod.render_lod(tree, camera=cam, blocks=args.budget, **keep, **kw)
            wall, cpu = time.perf_counter() - w0, time.process_time() - c0
            row = {"frame": k, "nodes": st.nodes, "levels": "/".join(
                       f"{lv}:{n}" for lv, n in sorted(st.levels.items())),
                   "decoded": st.decoded,
                   "wall_s": round(wall, 3), "cpu_s": round(cpu, 3),
                   "select_s": round(st.select_s, 3), "decode_s": round(st.decode_s, 3),
                   "render_s": round(st.render_s, 3)}  # fmt: skip
            if paged is not None:
                w0, c0 = time.perf_counter(), time.process_time()
                pimg, _ = lod.render_lod(tree, camera=cam, blocks=args.budget, atlas=paged, **kw)
                qw, qc = time.perf_counter() - w0, time.process_time() - c0
                row.update(paged_wall_s=round(qw, 3), paged_cpu_s=round(qc, 3),
                           psnr_walk_paged=psnr(img, pimg))  # fmt: skip
            if full is not None:
                w0, c0 = time.perf_counter(), time.process_time()
                ref = render(full, camera=cam, **kw)
                pw, pc = time.perf_counter() - w0, time.process_time() - c0
                row.update(plain_wall_s=round(pw, 3), plain_cpu_s=round(pc, 3),
                           ratio=round(cpu / pc, 2), psnr_walk_plain=psnr(img, ref))  # fmt: skip
                if paged is not None:
                    row.update(paged_ratio=round(qc / pc, 2), psnr_paged_plain=psnr(pimg, ref))
            rows.append(row)
            print(row, flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    later = sorted(r["cpu_s"] for r in rows[1:]) or [rows[0]["cpu_s"]]
    print(f"wrote {args.out}; frames after the first: median {later[len(later) // 2]:.2f} "
          f"CPU s, max {later[-1]:.2f}; first {rows[0]['cpu_s']:.2f} CPU s")  # fmt: skip
    return 0


def psnr(a, b) -> float:
    """PSNR in dB of RGB image ``a`` against ``b`` (both pre-multiplied, peak 1)."""
    import numpy as np

    rmse = float(np.sqrt(np.mean((a[..., :3] - b[..., :3]) ** 2)))
    return round(20 * np.log10(1 / rmse), 2) if rmse > 0 else float("inf")


if __name__ == "__main__":
    raise SystemExit(main())
