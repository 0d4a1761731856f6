"""What type 3's sign context would save a static coding of the long fit's residual: the
signs of the nonzero residuals at 1 bit each against their entropy given the sign
context (0..3, :func:`bounded_longfit._context`), alone and with the activity class
split at 4 (small residuals: their signs follow the neighbours' more?).

    python results/lossy/lossy20/sign_probe.py tas_monthly:1e-5
"""
import sys

import numpy as np
from common import residuals
from static_probe import contexts


def cond_bits(sign, ctx):
    bits = 0.0
    for c in np.unique(ctx):
        s = sign[ctx == c]
        p = s.mean()
        if 0 < p < 1:
            bits += s.size * -(p * np.log2(p) + (1 - p) * np.log2(1 - p))
    return bits


for name, rel, a, codec, q, (r, plan, w) in residuals(sys.argv[1]):
    flat = r.reshape(-1)
    act, sg = contexts(flat, *r.shape)
    nz = flat != 0
    sign = (flat[nz] < 0).astype(np.int64)
    small = np.minimum(np.abs(flat[nz]), 4)
    print(f"{name} {rel}: {nz.sum()} signs {nz.sum() / 8:.0f} B; given the sign context "
          f"{cond_bits(sign, sg[nz]) / 8:.0f} B; and |r| (1..4+) "
          f"{cond_bits(sign, sg[nz] * 8 + small) / 8:.0f} B", flush=True)
