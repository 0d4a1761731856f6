"""Where a float brick's bits go: the residual coding of mode 5 split into its parts.

For each volume (one brick, as the default 128^3 bricks take the fields measured), the
residuals of the best float Lorenzo predictor and of the fitted predictor
(:mod:`volpack.volume_codec.floatfit`) are taken from the encoder kernels, and their
cost is counted (``-log2`` of each model's probability, the models adapting as the
coders' do) in bits per voxel, split into the bit length's tree, the sign, the modelled
bits under the leading one and the plain bits below them:

* ``lorenzo``: the Lorenzo tool's coding (12-bit models, 3 sign contexts, 2 bits);
* ``lorenzo+coder``: the fit tool's coding of the same residuals (16-bit models, 27
  sign contexts, 3 bits);
* ``fit+coder``: the fit tool's stream (fitted predictor, its coding).

The totals match the coded streams to about 0.01 bit a voxel (the range coder's end
and the weights are not counted).

    python scripts/float_bits.py tgv_u tgv_pressure cam_u mri_dipy_float
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numba
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402

from volpack.volume_codec.floatpredict import context  # noqa: E402
from volpack.volume_codec.predict import bitlen  # noqa: E402

RATE12 = np.array([1, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5], dtype=np.int64)


@numba.njit(cache=False)
def _cost(models, k, bit, wide):
    """Bits of ``bit`` under model ``k``, then the model adapted (12-bit with the
    ``RATE`` schedule of the float tools, or 16-bit down to 2^-8 as predictfit's)."""
    st = models[k]
    if wide:
        p, n = st >> 8, st & 255
        pr = p / 65536.0
        r = min(int(math.log2(n + 1)) + 1, 8)
        p = p - (p >> r) if bit else p + ((65536 - p) >> r)
        models[k] = (p << 8) | min(n + 1, 255)
    else:
        p, n = st >> 4, st & 15
        pr = p / 4096.0
        r = RATE12[n]
        p = p - (p >> r) if bit else p + ((4096 - p) >> r)
        models[k] = (p << 4) | min(n + 1, 15)
    return -math.log2(1.0 - pr if bit else pr)


@numba.njit(cache=False)
def split(r, shape, wide, sign27, nmant, out):
    """Add the bits of residuals ``r`` (C order, ``shape``) to ``out``: tree, sign,
    modelled bits, plain bits."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    init = (32768 << 8) if wide else (2048 << 4)
    tree = np.full(128 * 128, init, np.int64)
    sign = np.full(27, init, np.int64)
    mant = np.full(65 << 3, init, np.int64)
    el = np.zeros(r.size, np.int64)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                ctx, sctx = context(el, r, i, x, y, z, ny, nx)  # the coders' own contexts
                if sign27:
                    sw = np.sign(r[i - 1]) + 1 if x > 0 else 1
                    sn = np.sign(r[i - nx]) + 1 if y > 0 else 1
                    su = np.sign(r[i - nx * ny]) + 1 if z > 0 else 1
                    sctx = 9 * sw + 3 * sn + su
                v = r[i]
                m = -v if v < 0 else v
                nb = bitlen(m)
                node = 1
                for j in range(6, -1, -1):
                    bit = (nb >> j) & 1
                    out[0] += _cost(tree, ctx * 128 + node, bit, wide)
                    node = 2 * node + bit
                if nb > 0:
                    out[1] += _cost(sign, sctx, np.int64(v < 0), wide)
                    nm = min(nb - 1, nmant)
                    prefix = 1
                    for jm in range(nm):
                        bit = (m >> (nb - 2 - jm)) & 1
                        out[2] += _cost(mant, (nb << 3) + prefix, bit, wide)
                        prefix = 2 * prefix + bit
                    out[3] += nb - 1 - nm
                el[i] = nb
                i += 1


def residuals(a: np.ndarray):
    """(best Lorenzo predictor, its residuals, the fitted predictor's residuals or None)."""
    from volpack.volume_codec import floatfit as ff
    from volpack.volume_codec import floatpredict as fp
    from volpack.volume_codec.floatbits import to_signed

    s = to_signed(a).reshape(-1)
    f = a.astype(np.float64).reshape(-1)
    si, sf = fp.scratch(a.dtype)
    shape = np.array(a.shape, dtype=np.int64)
    width = np.int64(8 * a.itemsize)
    out = np.empty(8 * s.size + 1024, np.uint8)
    best = None
    for p in fp.usable(a.dtype):
        el, rs, state = fp._workspace(s.size)
        n = fp._encode_kernel(s, f, si, sf, shape, width, np.int64(p), out, el, rs, state)
        if best is None or n < best[0]:
            best = (n, p, rs)
    _, face, rl = best
    w = ff.fit(a)
    if w is None:
        return face, rl, None
    el, rs, models = ff._workspace(s.size)
    steps = ff._steps(a.shape)
    w64 = w.astype(np.float64)
    nobox = (np.zeros(1), steps[:1], np.zeros(3, np.int64))
    args = (s, f, si, sf, w64, steps, *nobox, shape, width, np.int64(face), True, out, el, rs, models)
    ff._encode_kernel(*args)
    return face, rl, rs


def main(argv: list[str] | None = None) -> int:
    names = argv if argv is not None else sys.argv[1:]
    print("| volume | coding | bits/voxel | length tree | sign | modelled bits | plain bits "
          "| ratio |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for name in names:
        a, _, _ = datasets.load(name)
        a = np.ascontiguousarray(a[:128, :128, :128])
        face, rl, rf = residuals(a)
        rows = [("lorenzo", rl, False, False, 2), ("lorenzo+coder", rl, True, True, 3)]
        if rf is not None:
            rows.append(("fit+coder", rf, True, True, 3))
        for label, r, wide, s27, nm in rows:
            c = np.zeros(4)
            split(r, np.array(a.shape, dtype=np.int64), wide, s27, nm, c)
            c /= r.size
            bits = 8 * a.itemsize
            print(f"| {name} | {label} | {c.sum():.2f} | {c[0]:.2f} | {c[1]:.2f} | {c[2]:.2f} "
                  f"| {c[3]:.2f} | {bits / c.sum():.4f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
