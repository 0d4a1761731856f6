"""Unshaded frames with narrowed tables through _near_run (session 37, rend37b; TRIED AND
NOT KEPT: it needs _near_run to stop before a clipped segment, a change reverted after
`probe_near.txt`, so on the committed code both settings take the plain loop): the
fast march with ``NEAR_RUN`` off (the plain loop, as every narrowed frame took before)
and on, in one process, interleaved round by round; CPU ms a frame (best of ``ROUNDS``),
segments, and whether the two images are the same bit for bit, at the peers
benchmark's first view (azimuth 30, 512^2, step 0.5, 2 threads), semi-transparent TF.

    PYTHONPATH=. python results/render/rend37b/probe_near.py VOLUME ...
"""

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "results" / "render" / "rend37"))
import bench_render_peers as peers  # noqa: E402
from probe import load  # noqa: E402

from volpack.render import raycast  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

ROUNDS = 7


def main(names):
    for name in names:
        vol, sp = load(name)
        prep = prepare_volume(vol, sp)
        for tfk in ("semi",):
            tf = TransferFunction(points=peers.tf_points(tfk, *peers.tf_base(vol)))
            cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
            res = {}
            for on in (False, True):
                raycast.NEAR_RUN = on
                img, st = raycast.render(prep, tf=tf, camera=cam, step=0.5, workers=2,
                                         render_stats=True)
                res[on] = [img, st.samples, []]
            for _ in range(ROUNDS):
                for on in (False, True):
                    raycast.NEAR_RUN = on
                    c = time.process_time()
                    raycast.render(prep, tf=tf, camera=cam, step=0.5, workers=2)
                    res[on][2].append(time.process_time() - c)
            same = np.array_equal(res[False][0], res[True][0]) and res[False][1] == res[True][1]
            t0, t1 = min(res[False][2]), min(res[True][2])
            print(f"{Path(name).name.split('.')[0]:12s} {tfk:6s} none  plain loop {1e3 * t0:6.1f} ms"
                  f"  near run {1e3 * t1:6.1f} ms  x {t1 / t0:.3f}  segments "
                  f"{res[True][1] / 1e6:5.2f} M  same image and count: {same}", flush=True)
    raycast.NEAR_RUN = True


if __name__ == "__main__":
    main(sys.argv[1:])
