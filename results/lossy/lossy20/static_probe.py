"""Static-table estimates of the long fit's residual in type 3's contexts: tokens as the
fast predictive coder's (zig-zag, 16 direct, 4 per octave, raw low bits), per-brick rANS
tables (their bytes counted), against type 3's coded bytes and the wavelet's, at the
encoder's shortest reach (static_probe.txt: a first version's run over the three reaches
the encoder tries).

    python results/lossy/lossy20/static_probe.py tgv_pressure:1e-5,tgv_vorticity:1e-3
"""
import sys

import numba
import numpy as np
from common import residuals

from volpack.volume_codec import bounded_longfit as lf
from volpack.volume_codec import fastpredict as fp


@numba.njit
def contexts(r, nz, ny, nx):
    act = np.empty(r.size, np.int64)
    sg = np.empty(r.size, np.int64)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                a, s = lf._context(r, i, z, y, x, ny, nx)
                act[i] = a
                sg[i] = s
                i += 1
    return act, sg


def tokens(v, zigzag=True):
    """(fast predictive tokens, raw bit count) of ``v`` zig-zagged (or ``v >= 0`` itself)."""
    u = np.where(v >= 0, 2 * v, -2 * v - 1) if zigzag else v
    n = np.floor(np.log2(np.maximum(u, 1))).astype(np.int64) + 1
    tok = np.where(u < fp.DIRECT, u, fp.DIRECT + 4 * (n - 5) + ((u >> np.maximum(n - 3, 0)) & 3))
    raw = np.where(u < fp.DIRECT, 0, n - 3)
    return tok, int(raw.sum())


def cost(tok, ctx, raw, nctx):
    counts = np.zeros((nctx, fp.NTOK), np.int64)
    np.add.at(counts, (ctx, tok), 1)
    used = np.flatnonzero(counts.sum(1))
    counts = counts[used]
    best = None
    for top in range(1, counts.shape[0] + 1):  # merge the highest classes into one
        m = counts[:top].copy()
        m[top - 1] += counts[top:].sum(0)
        f = fp.rans.normalise(m)
        u = m > 0
        sym = -(m[u] * np.log2(f[u] / fp.rans.TOTAL)).sum() / 8
        tab = fp._table_bytes(f)
        if best is None or sym + tab < best[0] + best[1]:
            best = (sym, tab, top)
    sym, tab, top = best
    return sym + tab + raw / 8, tab, top


def main():
    for name, rel, a, codec, q, (r, plan, w) in residuals(sys.argv[1]):
        flat = r.reshape(-1)
        t3 = len(lf.code_residuals(r))
        head, res = lf.encode_head(r, plan, w)
        wav = len(codec._inner().encode(res))
        act, sg = contexts(flat, *r.shape)
        tok, raw = tokens(flat)
        out = [f"{name} {rel} {plan.reach}: type3 {t3} wavelet {wav} raw {raw // 8}"]
        # sign by flipping: negate where the sign context says negative is likelier
        flip = np.where((sg == 0), -flat, flat)
        tokf, rawf = tokens(flip)
        for label, tk, rw, c, n in (
            ("act", tok, raw, act, 48),
            ("act+sign", tok, raw, act * 4 + sg, 192),
            ("act,flip0", tokf, rawf, act, 48),
            ("act/2", tok, raw, act // 2, 24),
            ("act/2+sign", tok, raw, (act // 2) * 4 + sg, 96),
        ):
            b, tab, top = cost(tk, c, rw, n)
            out.append(f"  {label}: {b:.0f} B (tables {tab}, {top} ctx) {100 * (b / t3 - 1):+.2f} % vs type3")
        print("\n".join(out), flush=True)


if __name__ == "__main__":
    main()
