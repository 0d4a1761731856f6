"""Is refinement's cost the tables' memory? (session 39, rend39; a diagnosis, nothing kept)
The opaque frames with tables of 256 (default; the full-step and two refinement tables,
1 MB each, float32 RGBA) and 64 entries (64 KB each), with and without refinement; one
thread, CPU ms best of 5, interleaved.

    PYTHONPATH=. python results/render/rend39/table_size.py VOLUME ...
"""

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import first_view  # noqa: E402

from volpack.render import raycast as rc  # noqa: E402

CASES = {"256 r3": (256, 3), "256 r1": (256, 1), "64 r3": (64, 3), "64 r1": (64, 1)}


def main(names):
    for name in names:
        nm, prep, tf, cam = first_view(name, "opaque")
        for sh in ("none", "phong"):
            res = {}
            for k, (n, r) in CASES.items():
                _, st = rc.render(prep, tf=tf, camera=cam, step=0.5, shading=sh, table_size=n,
                                  refine=r, workers=1, render_stats=True)  # fmt: skip
                res[k] = [st.samples, []]
            for _ in range(5):
                for k, (n, r) in CASES.items():
                    c = time.process_time()
                    rc.render(prep, tf=tf, camera=cam, step=0.5, shading=sh, table_size=n,
                              refine=r, workers=1)  # fmt: skip
                    res[k][1].append(time.process_time() - c)
            t = {k: min(v[1]) * 1e3 for k, v in res.items()}
            for n in (256, 64):
                extra = (res[f"{n} r3"][0] - res[f"{n} r1"][0]) / 1e6
                cost = t[f"{n} r3"] - t[f"{n} r1"]
                print(f"{nm:10s} {sh:5s} tables {n:3d}: frame {t[f'{n} r3']:6.1f} ms, without "
                      f"refinement {t[f'{n} r1']:6.1f} ms: refinement {cost:5.1f} ms for "
                      f"{extra:.2f} M extra samples", flush=True)  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1:])
