"""Where the default lossy decode spends its time (one process, warm): per cell the
payload kind, volpack's best decode against SZ3's (interleaved CPU time), per-stage ns a
voxel (bench_lossy_decode's stage timers plus the long fit's residual decoders and walk)
and cProfile's top functions.

    PYTHONPATH=<tree> python results/lossy/ldec36b/stages.py --rel 1e-3 climate_t tgv_vorticity
"""

import argparse
import cProfile
import functools
import io
import pstats
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
import datasets  # noqa: E402
from bench_lossy_decode import StageTimer, best_interleaved, payload_paths  # noqa: E402

from volpack import api, peers  # noqa: E402
from volpack.volume_codec import bounded_longfit  # noqa: E402

EXTRA = {"residual_adaptive": "decode_residuals", "residual_static": "decode_static",
         "walk": "walk"}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rel", type=float, default=1e-3)
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--cprofile", type=int, default=12, help="top N functions (0: none)")
    ap.add_argument("fields", nargs="+")
    args = ap.parse_args()
    timer = StageTimer()
    for stage, name in EXTRA.items():
        timer._wrap(bounded_longfit, name, stage)
    sz3 = peers.sz3_encoder()
    print("field,rel,voxels,path,ratio,ns_volpack,ns_sz3,x_sz3,stages(ns/voxel)")
    for name in args.fields:
        a = np.ascontiguousarray(datasets.load(name)[0])
        e = float(f"{(float(a.max()) - float(a.min())) * args.rel:.4g}")
        b = bytes(api.compress_array(a, max_error=e))
        s = sz3(a, e)
        out = api.decompress_array(b)
        assert np.abs(out.astype(np.float64) - a).max() <= e
        calls = {"volpack": functools.partial(api.decompress_array, b),
                 "sz3": functools.partial(peers.sz3_decode, s, a.dtype, a.shape)}
        best = best_interleaved(calls, args.rounds)
        timer.acc.clear()
        import time
        t0 = time.process_time()
        for _ in range(args.rounds):
            calls["volpack"]()
        total = (time.process_time() - t0) / args.rounds
        st = {k: 1e9 * v / args.rounds / a.size for k, v in timer.acc.items() if v}
        st["rest"] = 1e9 * total / a.size - sum(st.values())
        print(f"{name},{args.rel:g},{a.size},{payload_paths(b)},{a.nbytes / len(b):.2f},"
              f"{1e9 * best['volpack'] / a.size:.1f},{1e9 * best['sz3'] / a.size:.1f},"
              f"{best['sz3'] / best['volpack']:.3f},"
              + " ".join(f"{k}={v:.1f}" for k, v in sorted(st.items())), flush=True)
        if args.cprofile:
            pr = cProfile.Profile()
            pr.enable()
            for _ in range(args.rounds):
                calls["volpack"]()
            pr.disable()
            sio = io.StringIO()
            pstats.Stats(pr, stream=sio).sort_stats("tottime").print_stats(args.cprofile)
            print("\n".join("    " + ln for ln in sio.getvalue().splitlines()
                            if ln.strip() and not ln.startswith("   Ordered")), flush=True)


if __name__ == "__main__":
    main()
