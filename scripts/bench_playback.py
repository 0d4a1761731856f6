"""Playback: animation frames/s against quality, octree image error against the node
budget, and tetrahedral-mesh ray casting speed.

Animation player (thesis Table 2.10 in spirit)
    The bundled MRI (84 x 128 x 128, u8) moving by a sub-voxel step each frame
    (``volpack.synth.translate``, 12 frames), coded with GOPs ``I``, ``IPP`` and
    ``IBBPBBPBB`` at max error 1, 4 and 16 with the arithmetic and the Huffman coder.
    :func:`volpack.animation.player.play` decodes on the playback schedule; each frame is rendered at
    256 x 256 (pre-integrated, Phong, 2 threads). Reported: ratio, PSNR over all frames,
    decode frames/s, render frames/s, and both together.
Level of detail (thesis §2.3)
    The head CT (108 x 256 x 256) as a lossless octree (k = 16); four views 90 degrees
    apart at 384 x 384 with the ``ct-bone`` preset, each drawn from the nodes
    :func:`volpack.octree.select.by_view` chooses within budgets of 16 .. 2048 nodes, against
    the full-resolution render of the same view: PSNR, nodes drawn, bytes read, time.
Tetrahedral meshes
    A Kuhn grid of 216k tetrahedra and the sfepy/tetgen meshes when fetched, 512 x 512,
    shaded: cell segments per second (there is no sort: rays walk the face graph).

    python scripts/bench_playback.py [--out results/playback]
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "tests"))


def psnr(a, b, peak) -> float:
    mse = float(np.mean((np.asarray(a, float) - np.asarray(b, float)) ** 2))
    return 99.0 if mse == 0 else 10 * math.log10(peak * peak / mse)


def bench_player(tmp: Path) -> list[dict]:
    from volpack import synth
    from volpack.animation import player
    from volpack.animation import stream as animation
    from volpack.demo import load_demo_volume
    from volpack.render.camera import Camera
    from volpack.render.raycast import render
    from volpack.render.transfer import load_tf

    frames = synth.translate(load_demo_volume().data, 12, (0.5, 0.25, -0.75))
    raw = frames.nbytes
    lo, hi = float(frames.min()), float(frames.max())
    tf = load_tf("auto", lo, hi, dtype=frames.dtype)
    cam = Camera(size=(256, 256), azimuth=30, elevation=20)
    render(frames[0], tf=tf, camera=Camera(size=(8, 8)), value_range=(lo, hi))
    rows = []
    for gop in ("I", "IPP", "IBBPBBPBB"):
        for err in (1, 4, 16):
            for coder in ("arith", "huffman"):
                path = tmp / f"a-{gop}-{err}-{coder}.vpk"
                animation.compress(frames, str(path), gop_string=gop, max_error=err, coder=coder,
                                   force=True)  # fmt: skip
                dec = ren = 0.0
                got = np.empty_like(frames)
                for frame, st, _ in player.play(str(path)):
                    dec += st.decode_ms / 1000
                    t0 = time.perf_counter()
                    render(frame.astype(np.float32), tf=tf, camera=cam, value_range=(lo, hi),
                           shading="phong", workers=2)  # fmt: skip
                    ren += time.perf_counter() - t0
                    got[st.t] = frame
                n = len(frames)
                rows.append({"gop": gop, "max_error": err, "coder": coder,
                             "ratio": round(raw / path.stat().st_size, 2),
                             "psnr": round(psnr(got, frames, 255), 2),
                             "decode_fps": round(n / dec, 1), "render_fps": round(n / ren, 2),
                             "fps": round(n / (dec + ren), 2)})  # fmt: skip
                print("player", rows[-1], flush=True)
    return rows


def bench_lod(tmp: Path) -> list[dict]:
    import datasets

    from volpack.octree import Octree, build
    from volpack.render.camera import Camera
    from volpack.render.lod import render_lod
    from volpack.render.raycast import render
    from volpack.render.transfer import preset
    from volpack.volume import Volume

    vol, sp, _ = datasets.load("ct_head")
    path = tmp / "ct.vpk"
    build(Volume(vol, spacing=sp), str(path), block=16, workers=2)
    lo, hi = float(vol.min()), float(vol.max())
    tf = preset("ct-bone", lo, hi)
    full = np.ascontiguousarray(vol, np.float32)
    rows = []
    for az in (0.0, 90.0, 180.0, 270.0):
        cam = Camera(size=(384, 384), azimuth=az, elevation=20)
        ref = render(full, spacing=sp, tf=tf, camera=cam, value_range=(lo, hi), shading="phong")
        with Octree(str(path), cache_bytes=1 << 30) as t:  # a fresh cache per view
            for budget in (16, 64, 256, 1024, 2048):
                t0 = time.perf_counter()
                img, st = render_lod(t, tf=tf, camera=cam, blocks=budget, value_range=(lo, hi),
                                     shading="phong")  # fmt: skip
                secs = time.perf_counter() - t0
                e = float(np.sqrt(np.mean((img[..., :3] - ref[..., :3]) ** 2)))
                rows.append({"azimuth": az, "budget": budget, "nodes": st.nodes,
                             "levels": "/".join(f"{k}:{v}" for k, v in sorted(st.levels.items())),
                             "bytes_read": st.bytes_read, "seconds": round(secs, 3),
                             "rmse": round(e, 5),
                             "psnr": round(99.0 if e == 0 else 20 * math.log10(1 / e), 2)})  # fmt: skip
                print("lod", rows[-1], flush=True)
    return rows


def bench_mesh() -> list[dict]:
    from test_render_tetra import TF, kuhn_grid, linear

    from volpack.render.camera import Camera
    from volpack.render.tetra import render_mesh

    meshes = []
    pts, tets = kuhn_grid(34)
    meshes.append(("kuhn34", pts, tets, linear(pts[:, ::-1])))
    rows = []
    for name, pts, tets, sc in meshes:
        render_mesh(pts, tets, sc, tf=TF, camera=Camera(size=(8, 8)))
        for workers in (1, 2):
            img, st = render_mesh(pts, tets, sc, tf=TF, camera=Camera(size=(512, 512)),
                                  shading="phong", workers=workers, render_stats=True)  # fmt: skip
            rows.append({"mesh": name, "tets": len(tets), "workers": workers,
                         "seconds": round(st.seconds, 3), "segments": st.samples,
                         "segments_per_s": round(st.samples / st.seconds)})  # fmt: skip
            print("mesh", rows[-1], flush=True)
    return rows


def chart(prow, lrow, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    for gop in ("I", "IPP", "IBBPBBPBB"):
        for coder, mk in (("arith", "o-"), ("huffman", "s--")):
            sel = [r for r in prow if r["gop"] == gop and r["coder"] == coder]
            a.plot([r["psnr"] for r in sel], [r["decode_fps"] for r in sel], mk,
                   label=f"{gop} {coder}")  # fmt: skip
    a.set_xlabel("PSNR (dB)")
    a.set_ylabel("decode frames/s (84x128x128)")
    a.set_title("Animation playback: decode speed vs quality")
    a.legend(fontsize=7)
    for az in sorted({r["azimuth"] for r in lrow}):
        sel = [r for r in lrow if r["azimuth"] == az]
        b.plot([r["budget"] for r in sel], [r["psnr"] for r in sel], "o-", label=f"azimuth {az:g}")
    b.set_xscale("log", base=2)
    b.set_xlabel("node budget (16^3 nodes)")
    b.set_ylabel("PSNR vs full-resolution render (dB)")
    b.set_title("Octree level of detail: image error vs budget")
    b.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "playback")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as d:
        prow = bench_player(Path(d))
        lrow = bench_lod(Path(d))
    mrow = bench_mesh()
    for name, rows in (("player.csv", prow), ("lod.csv", lrow), ("mesh.csv", mrow)):
        with open(args.out / name, "w", newline="") as f:
            wr = csv.DictWriter(f, fieldnames=list(rows[0]))
            wr.writeheader()
            wr.writerows(rows)
    chart(prow, lrow, args.out / "playback.png")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
