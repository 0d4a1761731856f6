"""NEAR_RUN_MIN swept (session 39, rend39): unshaded semi-transparent frames (pre-integrated,
nearest-entry tables, :func:`_near_run`), one thread, CPU ms best of 5 interleaved, segments,
and whether each image equals the one at NEAR_RUN_MIN = 1 (today's rule) bit for bit.

    PYTHONPATH=. python results/render/rend39/near_min.py VOLUME ...
"""

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import first_view  # noqa: E402

from volpack.render import raycast as rc  # noqa: E402

VALUES = (1, 2, 4, 8, 16, 10**9)


def main(names):
    for name in names:
        nm, prep, tf, cam = first_view(name, "semi")

        def go(v, stats=False, prep=prep, tf=tf, cam=cam):
            rc.NEAR_RUN_MIN = v
            try:
                return rc.render(prep, tf=tf, camera=cam, step=0.5, workers=1,
                                 render_stats=stats)  # fmt: skip
            finally:
                rc.NEAR_RUN_MIN = 1

        res = {}
        for v in VALUES:
            img, st = go(v, True)
            res[v] = [img, st.samples, []]
        for _ in range(5):
            for v in VALUES:
                c = time.process_time()
                go(v)
                res[v][2].append(time.process_time() - c)
        b = min(res[1][2])
        for v, (img, n, ts) in res.items():
            print(f"{nm:12s} NEAR_RUN_MIN {v if v < 10**9 else 'off':>4} cpu {min(ts) * 1e3:6.1f} "
                  f"ms ({min(ts) / b:.3f}x)  segments {n / 1e6:5.2f} M  same image "
                  f"{np.array_equal(img, res[1][0])}", flush=True)  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1:])
