"""NEAR_RUN_MIN swept (session 39, rend39): unshaded semi-transparent frames (pre-integrated,
nearest-entry tables, :func:`_near_run`), one thread, CPU ms best of 5 interleaved, segments,
and whether each image equals the one at NEAR_RUN_MIN = 1 (today's rule) bit for bit.

    git apply results/render/rend39/tried_near_run_min.diff   # the knob; revert after
    PYTHONPATH=. python results/render/rend39/near_min.py VOLUME ...
"""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import first_view, interleaved_cpu, knobs  # noqa: E402

from volpack.render import raycast as rc  # noqa: E402

VALUES = (1, 2, 4, 8, 16, 10**9)


def main(names):
    for name in names:
        nm, prep, tf, cam = first_view(name, "semi")

        def go(v, stats=False, prep=prep, tf=tf, cam=cam):
            with knobs(rc, {"NEAR_RUN_MIN": v}):
                return rc.render(prep, tf=tf, camera=cam, step=0.5, workers=1,
                                 render_stats=stats)  # fmt: skip

        res = {}
        for v in VALUES:
            img, st = go(v, True)
            res[v] = [img, st.samples, []]
        times = interleaved_cpu({v: lambda v=v: go(v) for v in VALUES}, 5)
        for v in VALUES:
            res[v][2] = times[v]
        b = min(res[1][2])
        for v, (img, n, ts) in res.items():
            print(f"{nm:12s} NEAR_RUN_MIN {v if v < 10**9 else 'off':>4} cpu {min(ts) * 1e3:6.1f} "
                  f"ms ({min(ts) / b:.3f}x)  segments {n / 1e6:5.2f} M  same image "
                  f"{np.array_equal(img, res[1][0])}", flush=True)  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1:])
