"""Where the opaque frames of a volume with a fill lose PSNR (session 37, rend37): the
same field with the fill as NaN (empty, filled with a clear value inside the tables)
against the fill as data, each against its own step-0.125 image, and at step 0.25.

    PYTHONPATH=. python results/render/rend37/probe_edges.py > results/render/rend37/probe_edges.txt
"""

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_render_peers as peers  # noqa: E402
from probe import load, psnr  # noqa: E402

from volpack.render import raycast  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402


def main(names):
    for name in names:
        vol, sp = load(name)
        fill = float(np.nanmin(vol))
        nan = vol.copy()
        nan[vol == fill] = np.nan
        for tfk in ("semi", "opaque"):
            tf = TransferFunction(points=peers.tf_points(tfk, *peers.tf_base(vol)))
            cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
            for sh in ("none", "phong"):
                for label, v in (("fill as data", vol), ("fill as NaN", nan)):
                    ref = raycast.render(v, spacing=sp, tf=tf, camera=cam, step=0.125, shading=sh)
                    out = []
                    for kw in (dict(step=0.5), dict(step=0.25), dict(step=0.5, refine=1)):
                        img = raycast.render(v, spacing=sp, tf=tf, camera=cam, shading=sh, **kw)
                        out.append(f"{kw}: {psnr(img, ref):5.1f}")
                    print(f"{Path(name).name.split('.')[0]:12s} {tfk:6s} {sh:5s} {label:12s} "
                          + "  ".join(out) + " dB", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or ["storm_u"])
