"""Counters for the fast march's opaque unshaded frames (session 38, rend38; issue 22):
segments, those with opacity, empty-space tests and jumps per frame, decoded from the
per-row counts that ``count.patch`` packs into ``row_cols[:, 2]`` (segments in bits
0-17, visible in 18-33, tests in 34-47, jumps from 48). Run from the repository root
with the patch applied, then revert it:

    git apply results/render/rend38/count.patch
    PYTHONPATH=. python results/render/rend38/count.py VOLUME ...
    git checkout volpack/render/raycast.py
"""

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "results" / "render" / "rend37"))
import bench_render_peers as peers  # noqa: E402
from probe import load  # noqa: E402

from volpack.render import raycast  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

cap = {}
orig = raycast.finish_render


def fin(out, rs, t0, st):
    cap["rows"] = rs.copy()
    return orig(out, rs, t0, st)


raycast.finish_render = fin
raycast.NEAR_RUN = False
for name in sys.argv[1:]:
    vol, sp = load(name)
    prep = prepare_volume(vol, sp)
    tf = TransferFunction(points=peers.tf_points("opaque", *peers.tf_base(vol)))
    cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
    for sz in (8, 512):
        c0 = time.process_time()
        for _ in range(5):
            raycast.render(
                prep,
                tf=tf,
                camera=Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(sz, sz)),
                step=0.5,
                shading="none",
                workers=2,
            )
        print(f"{sz}x{sz} frame cpu {(time.process_time() - c0) / 5 * 1e3:.1f} ms")
    for b in (4, 2):
        raycast.FINE_BRICK = b
        raycast.render(
            prepare_volume(vol, sp) if b == 2 else prep,
            tf=tf,
            camera=cam,
            step=0.5,
            shading="none",
            workers=2,
        )
        r = cap["rows"]
        seg = (r & ((1 << 18) - 1)).sum()
        vis = ((r >> 18) & ((1 << 16) - 1)).sum()
        tests = ((r >> 34) & ((1 << 14) - 1)).sum()
        jumps = (r >> 48).sum()
        print(
            f"{name.split('/')[-1]:12s} brick {b} segments {seg / 1e6:.2f} M  visible (a>0) {vis / 1e6:.2f} M  clear {(seg - vis) / 1e6:.2f} M  tests {tests / 1e6:.3f} M  jumps {jumps / 1e6:.3f} M",
            flush=True,
        )
