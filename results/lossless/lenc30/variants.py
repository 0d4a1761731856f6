"""Per brick and variant of the lossless encoder's integer chain: the real payload size
(the whole brick) against its size on a central slab of the brick, with CPU seconds.

    PYTHONPATH=. python results/lossless/lenc30/variants.py OUT.csv NAME...

Variants follow ``lossless._encode_fit``'s chain as the exhaustive selection runs it (each
one with the settings the chain had reached), plus the other candidates of
``LosslessCodec.encode`` (wavelet, version-1 predictor on values and ranks, labels).
"""

from __future__ import annotations

import csv
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load  # noqa: E402

from volpack.volume_codec import bgmask, bricks, predict, predictfit  # noqa: E402
from volpack.volume_codec import palette as pal  # noqa: E402
from volpack.volume_codec.codec import WaveletCodec  # noqa: E402

FIELDS = ["volume", "brick", "shape", "variant", "full", "full_s", "sample", "sample_s"]


SAMPLE = os.environ.get("SAMPLE", "central:4")  # central:F (a 1/F slab) or spread:N:T


def slab(v):
    """The slices sampled: a central slab, or N slabs of T slices spread evenly (joined)."""
    nz = v.shape[0]
    kind, *p = SAMPLE.split(":")
    if kind == "central":
        k = max(4, nz // int(p[0]))
        z0 = (nz - k) // 2
        return slice(z0, z0 + k)
    n, t = int(p[0]), int(p[1])
    if n * t >= nz:
        return slice(0, nz)
    starts = [round((i + 0.5) * nz / n - t / 2) for i in range(n)]
    return np.concatenate([np.arange(z, z + t) for z in starts])


def timed(f):
    t = time.process_time()
    r = f()
    return r, time.process_time() - t


def rows_of_brick(brick):
    out = []
    v = brick.astype(np.int64)
    lo, hi = int(v.min()), int(v.max())
    if lo == hi:
        return out
    s = slab(v)
    vs = v[s]

    def add(name, full_f, sample_f):
        fb, ft = timed(full_f)
        sb, st = timed(sample_f) if sample_f else (None, 0.0)
        out.append([name, len(fb), ft, None if sb is None else len(sb), st])
        return fb

    add("wavelet", lambda: WaveletCodec().encode(brick), lambda: WaveletCodec().encode(brick[s]))
    add("v1", lambda: predict.encode(v, lo, hi), lambda: predict.encode(vs, lo, hi))
    p, t = timed(lambda: pal.build(v))
    out.append(["unique", len(p), t, None, 0.0])
    doms = [("values", v, lo, hi)]
    if 2 < len(p) < hi - lo + 1 and len(p) <= pal.MAX_PALETTE:
        r = pal.to_ranks(v, p)
        doms.append(("ranks", r, 0, len(p) - 1))
        add(
            "v1ranks",
            lambda: predict.encode(r, 0, len(p) - 1),
            lambda: predict.encode(r[s], 0, len(p) - 1),
        )
    tried = []
    for name, d, a, b in doms:
        fits, t = timed(lambda d=d, a=a: predictfit.fit(d - a))
        out.append([f"fit_{name}", 0, t, None, 0.0])
        head = len(pal.pack(p)) if name == "ranks" else len(pal.pack_range(lo, hi))
        add(
            name,
            lambda d=d, a=a, b=b, f=fits: predictfit.encode(d, a, b, fitted=f[0]),
            lambda d=d, a=a, b=b, f=fits: predictfit.encode(d[s], a, b, fitted=f[0]),
        )
        out[-1][1] += head  # full sizes: the payload (head, mask section, stream)
        tried.append((out[-1][1], name, d, a, b, fits, head))
    best, name, d, a, b, fits, head = min(tried, key=lambda t: t[0])
    m, ms, extra = None, None, head
    masked, t = timed(lambda: bgmask.choose(d))
    out.append(["choose", 0, t, None, 0.0])
    if masked is not None:
        fill, mm = masked
        sec = len(bgmask.encode(fill - a, mm))
        sec_s = len(bgmask.encode(fill - a, mm[s]))
        add(
            "mask",
            lambda: predictfit.encode(d, a, b, mask=mm, fitted=fits[0]),
            lambda: predictfit.encode(d[s], a, b, mask=mm[s], fitted=fits[0]),
        )
        out[-1][1] += head + sec
        out[-1][3] += sec_s
        if out[-1][1] < best:
            best, m, ms, extra = out[-1][1], mm, mm[s], head + sec
    fitted = fits[0]

    def step(label, **kw):
        add(
            label,
            lambda: predictfit.encode(d, a, b, mask=m, **kw),
            lambda: predictfit.encode(d[s], a, b, mask=ms, **kw),
        )
        out[-1][1] += extra
        return out[-1][1]

    n = step("one", fitted=fits[1])
    if n < best:
        best, fitted = n, fits[1]
    n = step("low", fitted=fitted, low=True)
    low = n < best
    best = min(best, n)
    n = step("tex", fitted=fitted, low=low, tex=True)
    tex = n < best
    best = min(best, n)
    step("mix", fitted=fitted, low=low, tex=tex, mix=True)
    out.append(["chosen_domain", int(name == "ranks"), 0.0, int(m is not None), 0.0])
    return out


def main():
    path, names = sys.argv[1], sys.argv[2:]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(FIELDS)
        for nm in names:
            vol, _, _ = load(nm)
            vol = np.asarray(vol)
            if vol.dtype.kind not in "iu":
                continue
            vol = vol.reshape(vol.shape[-3:]) if vol.ndim > 3 and vol.shape[0] == 1 else vol
            if vol.ndim != 3:
                vol = vol.reshape((-1,) + vol.shape[-2:])
            bs = bricks.default_brick(vol.shape, vol.dtype, False, "auto")
            t0 = time.process_time()
            k = 0
            for z in range(0, vol.shape[0], bs[0]):
                for y in range(0, vol.shape[1], bs[1]):
                    for x in range(0, vol.shape[2], bs[2]):
                        b = np.ascontiguousarray(vol[z : z + bs[0], y : y + bs[1], x : x + bs[2]])
                        if k == 0:
                            rows_of_brick(b)  # warm-up: the kernels compile on first use
                        for r in rows_of_brick(b):
                            w.writerow([nm, k, "x".join(map(str, b.shape))] + r)
                        k += 1
            f.flush()
            print(nm, vol.shape, vol.dtype, k, f"{time.process_time() - t0:.1f}s", flush=True)


if __name__ == "__main__":
    main()
