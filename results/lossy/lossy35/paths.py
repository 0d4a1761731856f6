"""Bytes of each coding the bounded encoder makes of one brick (diagnosis, one process).

Run: PYTHONPATH=. python results/lossy/lossy35/paths.py F.npy REL [REL...]
"""

from __future__ import annotations

import sys

import numpy as np

from volpack.volume_codec import bounded_interp as bi
from volpack.volume_codec.lossy import BoundedCodec


def main() -> None:
    x = np.load(sys.argv[1])
    fin = x[np.isfinite(x)]
    lo, hi = float(fin.min()), float(fin.max())
    for rel in map(float, sys.argv[2:]):
        e = rel * (hi - lo)
        c = BoundedCodec.plan(x.dtype, lo, hi, e, effort="max")
        clean, mask = x, None
        q = c._quantize(clean)
        print(f"rel {rel:g} E {e:.4g} step {c.step:.4g} qdtype {c.qdtype}")
        for t, b in c._code_quantised(q):
            print(f"  quantised tier {t}: {len(b)}")
        print(f"  coef: {len(c._coef_candidate(x, clean, mask)[0])}")
        print(f"  cdf97: {[len(m[0]) for m in c._cdf97_candidates(x, clean, mask)]}")
        t, m = c._interp_candidate(x, clean, mask)
        print(f"  interp (tier {t}): {len(m[0])}")
        g = clean.astype(np.float64)
        for kind, perms in bi.TRIED:
            for perm in perms:
                _, found = bi._walk_codings(g, c.step, perm, kind, bi.CODINGS, True)
                print(f"    kind {kind} perm {perm}: " + ", ".join(
                    f"{k} {v[0] / 8:.0f}" for k, v in found.items()))
        for t, b in c._longfit(q, 10**9):
            print(f"  longfit tier {t}: {len(b)}")


if __name__ == "__main__":
    main()
