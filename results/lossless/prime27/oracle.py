"""Bound on what primed models could win (issue 20): every version-2 predictive stream is
coded twice, the second pass starting from the states the first pass ended with (an
oracle: it cannot be decoded). Prints file bytes per volume: as coded, and with the
oracle carrying (a) the 16-bit models, (b) those and the mix's models and weights,
(c) everything adaptive (also the bias sums and the local fit's sums).

    python results/lossless/prime27/oracle.py NAME... [--effort max]
"""

import argparse
import sys
import time

import numpy as np

sys.path[:0] = [".", "scripts"]  # this worktree's volpack (run from its root)
from datasets import load  # noqa: E402

from volpack import api  # noqa: E402
from volpack.volume_codec import predictfit  # noqa: E402

REAL = predictfit._encode_kernel
from volpack.volume_codec.residmix import B_LEVEL, W_BASE  # noqa: E402

CARRY = {"models": (17,), "models+mix": (17, 18), "all": (14, 15, 16, 17, 18, 19)}
# the mix's weights alone; its models 2-4 alone; and the models (16-bit and 2-4) with
# their use counts capped at c (a prior as strong as c symbols: it still adapts fast)
CARRY.update({"weights": ("w",), "mixmodels": ("m",)})
# the mix's models 2-3 (activity: wide, slice before) apart from its model 4 (level)
CARRY.update({"mix23": ("m23",), "mix4": ("m4",)})
CARRY.update({f"models+mix,count<={c}": (17, 18, -c) for c in (2, 8, 32)})


def _capped(st, c):
    return (st & ~np.uint32(255)) | np.minimum(st & np.uint32(255), np.uint32(c))


def oracle(keep):
    def run(*args):
        args = list(args)
        first = [a.copy() if isinstance(a, np.ndarray) else a for a in args]
        first[11] = np.zeros_like(args[11])
        if REAL(*first) < 0:
            return REAL(*args)
        cap = next((-k for k in keep if isinstance(k, int) and k < 0), None)
        for k in keep:  # the learnt states go into the real pass
            if k == "w":
                args[18][W_BASE:] = first[18][W_BASE:]
            elif k == "m":
                args[18][:W_BASE] = first[18][:W_BASE]
            elif k == "m23":
                args[18][:B_LEVEL] = first[18][:B_LEVEL]
            elif k == "m4":
                args[18][B_LEVEL:W_BASE] = first[18][B_LEVEL:W_BASE]
            elif k > 0:
                args[k][...] = first[k]
        if cap is not None:
            args[17][...] = _capped(args[17], cap)
            args[18][:W_BASE] = _capped(args[18][:W_BASE], cap)
        return REAL(*args)

    return run


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("names", nargs="+")
    ap.add_argument("--effort", default=None)
    ap.add_argument(
        "--variants", default=",".join(CARRY), help="comma-separated; ';' for the capped"
    )
    a = ap.parse_args()
    opts = {"effort": a.effort} if a.effort else {}
    print("volume,voxels,variant,bytes,saving_bytes,saving_pct,seconds", flush=True)
    for name in a.names:
        vol, _, _ = load(name)
        base = None
        for variant in ["coded"] + [v.replace(";", ",") for v in a.variants.split(",")]:
            predictfit._encode_kernel = REAL if variant == "coded" else oracle(CARRY[variant])
            t = time.perf_counter()
            n = len(api.compress_array(vol, **opts))
            dt = time.perf_counter() - t
            base = n if base is None else base
            print(
                f"{name},{vol.size},{variant},{n},{base - n},{100 * (base - n) / base:.3f},{dt:.1f}",
                flush=True,
            )
        predictfit._encode_kernel = REAL


main()
