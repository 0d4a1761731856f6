"""The exact pre-integration against the default "fast" one, with and without refinement
(session 39, rend39): a volume's opaque unshaded frame, one thread, best of 3; PSNR
against the fast and the exact step-0.125 images and a "truth" (exact tables at step
1/32).

    PYTHONPATH=. python results/render/rend39/exact_probe.py bonsai_u8   # reads /tmp/rend39/vols
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "results" / "render" / "rend37"))
import bench_render_peers as peers  # noqa: E402
from probe import load, psnr  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import interleaved_cpu  # noqa: E402

from volpack.render import raycast as rc  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

VARIANTS = {
    "fast r3": {},
    "fast r1": {"refine": 1},
    "exact r1": {"refine": 1, "preint_method": "exact"},
    "exact r2": {"refine": 2, "preint_method": "exact"},
    "exact r3": {"preint_method": "exact"},
}


def main(names):
    for nm in names:
        vol, sp = load(f"/tmp/rend39/vols/{nm}.npy")
        prep = prepare_volume(vol, sp)
        tf = TransferFunction(points=peers.tf_points("opaque", *peers.tf_base(vol)))
        cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
        kw0 = {"tf": tf, "camera": cam, "shading": "none"}
        reff = rc.render(prep, step=0.125, workers=2, **kw0)
        refe = rc.render(prep, step=0.125, workers=2, preint_method="exact", **kw0)
        truth = rc.render(prep, step=1 / 32, workers=2, preint_method="exact", **kw0)
        print(f"{nm} ref fast vs truth {psnr(reff, truth):.2f} ref exact vs truth "
              f"{psnr(refe, truth):.2f}")  # fmt: skip
        res = {}
        for k, kw in VARIANTS.items():
            img, st = rc.render(prep, step=0.5, workers=1, render_stats=True, **kw0, **kw)
            res[k] = [img, st.samples, []]
        runs = {k: lambda kw=kw, prep=prep, kw0=kw0: rc.render(prep, step=0.5, workers=1, **kw0, **kw)
                for k, kw in VARIANTS.items()}  # fmt: skip
        for k, ts in interleaved_cpu(runs, 3).items():
            res[k][2] = ts
        for k, (img, n, ts) in res.items():
            print(f"{nm} none {k:9s} cpu {min(ts) * 1e3:6.1f} ms seg {n / 1e6:.2f} M  psnr vs "
                  f"fast ref {psnr(img, reff):5.2f} vs exact ref {psnr(img, refe):5.2f} vs "
                  f"truth {psnr(img, truth):5.2f}", flush=True)  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1:])
