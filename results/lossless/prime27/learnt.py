"""What the models learn (to calibrate prior.py): the states predictfit's zero-flag model
and first 14 length-bit models end a brick with (probability of a 0 / use count), for
a few activity classes (spread class 0), against prior.py's two-sided geometric prior
(uncapped). The brick: the first 128 x 128 of every slice, coded with tex and mix.

    python results/lossless/prime27/learnt.py NAME ALPHA BETA CLASS,CLASS,...
"""

import sys

import numpy as np

sys.path[:0] = [".", "scripts", "results/lossless/prime27"]
from datasets import load  # noqa: E402
from prior import MID, geometric_probs  # noqa: E402

from volpack.volume_codec import predictfit as pf  # noqa: E402
from volpack.volume_codec.predict import NLEN  # noqa: E402

REAL = pf._encode_kernel
seen = []


def grab(*a):
    r = REAL(*a)
    seen.append(a[17].copy())
    return r


def p(st):
    return int(st) >> 8, int(st) & 255


def main():
    name, alpha, beta, classes = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
    pf._encode_kernel = grab
    vol, _, _ = load(name)
    v = vol[:, :128, :128].astype(np.int64)
    pf.encode(v, int(v.min()), int(v.max()), tex=True, mix=True)
    m = seen[-1]
    for a in map(int, classes.split(",")):
        ctx = a * 3
        k = pf.M_LEN + ctx * NLEN
        p0, plen = geometric_probs(alpha * MID[a] + beta)
        q, n = p(m[pf.M_ZERO + 2 * ctx])
        print(
            f"class {a} (mid activity {MID[a]:.1f}): zero flag learnt {q / 65536:.3f}/{n}, prior {p0:.3f}"
        )
        print(
            "  length bits learnt",
            " ".join(f"{p(m[k + j])[0] / 65536:.2f}/{p(m[k + j])[1]}" for j in range(14)),
        )
        print("  length bits prior ", " ".join(f"{plen[j]:.2f}" for j in range(14)))


main()
