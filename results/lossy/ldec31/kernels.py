"""The long-fit decoder's parts alone, on the cells' stored streams: the residual
decoder (``decode_static``: tables and the kernel), the walk (``walk(..., decode=True)``:
the kernel's arrays and the kernel) and the arrays alone (``Plan.kernel_args``), best
CPU time of 3 x 5 calls in this process, ns a voxel. Run once per tree:

    PYTHONPATH=/tmp/ldec31/base python results/lossy/ldec31/kernels.py tgv128:1e-3 ...
"""

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import cells  # noqa: E402

import volpack  # noqa: E402
from volpack import api  # noqa: E402
from volpack.volume_codec import bounded_longfit as lf  # noqa: E402


def capture(name: str, rel: float) -> dict:
    """The arguments of the long-fit calls of one decode of the cell."""
    cap = {"ds": [], "walk": []}
    od, ow = lf.decode_static, lf.walk

    def ds(data, shape):
        cap["ds"].append((bytes(data), shape))
        return od(data, shape)

    def wk(q, r, plan, weights, qmax, decode):
        cap["walk"].append((r.copy(), plan, weights, qmax))
        return ow(q, r, plan, weights, qmax, decode)

    lf.decode_static, lf.walk = ds, wk
    try:
        api.decompress_array(cells.blob(name, rel))
    finally:
        lf.decode_static, lf.walk = od, ow
    return cap


def best(f, rounds=3, n=5) -> float:
    b = 1e9
    for _ in range(rounds * n):
        t = time.process_time()
        f()
        b = min(b, time.process_time() - t)
    return b


def main() -> None:
    print(f"# volpack from {Path(volpack.__file__).parent}")
    print("cell,voxels,static_ns,walk_ns,kernel_args_ms")
    for spec in sys.argv[1:]:
        name, rel = spec.split(":")
        cap = capture(name, float(rel))
        n = cells.field(name).size
        ts = sum(best(lambda a=a: lf.decode_static(*a)) for a in cap["ds"])
        tw = ta = 0.0
        for r, plan, w, qmax in cap["walk"]:
            q = np.empty(r.size, np.int64)
            tw += best(lambda q=q, r=r, p=plan, w=w, m=qmax: lf.walk(q, r, p, w, m, True))
            ta += best(lambda p=plan, w=w, m=qmax: p.kernel_args(w, m))
        print(f"{spec},{n},{1e9 * ts / n:.1f},{1e9 * tw / n:.1f},{1e3 * ta:.3f}", flush=True)


if __name__ == "__main__":
    main()
