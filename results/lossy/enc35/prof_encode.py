"""cProfile of the default lossy encode (warm kernel cache, one process).

    PYTHONPATH=. python results/lossy/enc35/prof_encode.py [fields...] > prof.txt
Fields: tuning fields of bench_lossy.py at 1e-3 and 1e-5 of the range, and the
``--gop IPPP --max-error 0.05`` animation of a 4-step drifting xray_1jzv series."""

from __future__ import annotations

import cProfile
import io
import pstats
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
import datasets  # noqa: E402

from volpack import api  # noqa: E402

FIELDS = ["climate_t", "hgt_500", "tgv_vorticity", "mri_piesno_noise"]


def drifting(n=4):
    x = np.ascontiguousarray(datasets.load("xray_1jzv")[0], dtype=np.float32)
    return np.stack([np.roll(x, t, axis=2) * np.float32(1 + 0.01 * t) for t in range(n)])


def jobs(names):
    for name in names:
        if name == "anim":
            from volpack.animation import stream as animation

            s = drifting()

            def run(s=s):
                buf = io.BytesIO()
                animation.compress(s, buf, gop_string="IPPP", max_error=0.05)
                return buf.getvalue()

            yield "anim_xray_1jzv_IPPP", run
            continue
        a = np.ascontiguousarray(datasets.load(name)[0])
        vr = float(a.max()) - float(a.min())
        for rel in (1e-3, 1e-5):
            yield f"{name}@{rel:g}", (lambda a=a, e=rel * vr: api.compress_array(a, max_error=e))


def main():
    names = sys.argv[1:] or [*FIELDS, "anim"]
    todo = list(jobs(names))
    for _, f in todo:  # warm: kernels compiled / loaded from the cache
        f()
    pr = cProfile.Profile()
    for label, f in todo:
        t0 = time.process_time()
        pr.enable()
        f()
        pr.disable()
        print(f"{label}: {time.process_time() - t0:.2f} s CPU", flush=True)
    st = pstats.Stats(pr)
    st.sort_stats("tottime").print_stats(25)
    st.sort_stats("cumulative").print_stats(40)


if __name__ == "__main__":
    main()
