"""Which bounded path wins on a field at each bound, and the bytes of every candidate.

python results/lossy/rough28/paths.py FIELD.npy|dataset-name [REL ...]
Prints per bound: each candidate's (tier, flag byte, bytes), the one kept.
"""

import sys
import time

sys.path.insert(0, "results/lossy/rough28")
from bound import load  # noqa: E402

from volpack.volume_codec import lossy  # noqa: E402

log = []
_orig = lossy.keep_faster


def spy(cands, saving=lossy.SLOW_MIN_SAVING):
    best = _orig(cands, saving)
    log.append([(t, m[0][0], len(m[0])) for t, m in cands] + [("kept", best[0][0], len(best[0]))])
    return best


lossy.keep_faster = spy


FLAGS = {
    1: "mask",
    2: "corr",
    4: "coef",
    8: "resid",
    16: "cdf97",
    32: "outl",
    64: "interp",
    128: "exact",
}


def names(f):
    return "+".join(v for k, v in FLAGS.items() if f & k) or "qvox"


if __name__ == "__main__":
    x = load(sys.argv[1])
    rels = [float(r) for r in sys.argv[2:]] or [1e-2, 1e-3, 1e-4, 1e-5]
    lo, hi = float(x.min()), float(x.max())
    for rel in rels:
        log.clear()
        c = lossy.BoundedCodec.plan(x.dtype, lo, hi, rel * (hi - lo))
        t = time.perf_counter()
        m = c.encode_measured(x)
        dt = time.perf_counter() - t
        print(
            f"rel {rel:g}: {len(m[0])} B, ratio {x.nbytes / len(m[0]):.3f}, bpv {8 * len(m[0]) / x.size:.3f}, {dt:.1f} s"
        )
        for call in log:
            print("   ", ", ".join(f"{t}:{names(f)}:{n}" for t, f, n in call))
