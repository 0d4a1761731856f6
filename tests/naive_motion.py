"""Slow, obviously correct references for volpack.animation.motion: block errors by numpy over
every candidate vector, the half-voxel grid by explicit taps, and compensation voxel by
voxel from the window formula."""

from __future__ import annotations

import math

import numpy as np

TAPS = np.array([-1, 4, -11, 40, 40, -11, 4, -1]) / 64.0


def shifted(ref, z0, y0, x0, shape, v):
    """The reference block at (z0, y0, x0) + whole-voxel vector v, border clamped."""
    idx = [
        np.clip(np.arange(o, o + n) + d, 0, s - 1)
        for o, n, d, s in zip((z0, y0, x0), shape, v, ref.shape)
    ]
    return ref[np.ix_(*idx)].astype(np.float64)


def exhaustive(cur, ref, radius, penalty=0.0):
    """Every block's best whole vector (quarter units) and cost, trying every vector
    and breaking ties by (length^2, z, y, x)."""
    nb = [-(-n // 8) for n in cur.shape]
    vecs = np.zeros((*nb, 3), np.int64)
    costs = np.zeros(nb)
    cands = [
        (dz * dz + dy * dy + dx * dx, dz, dy, dx)
        for dz in range(-radius, radius + 1)
        for dy in range(-radius, radius + 1)
        for dx in range(-radius, radius + 1)
    ]
    cands.sort()
    for b in np.ndindex(*nb):
        o = [8 * i for i in b]
        blk = cur[tuple(slice(a, a + 8) for a in o)].astype(np.float64)
        best = None
        for _, dz, dy, dx in cands:
            s = 64.0 * np.sum((blk - shifted(ref, *o, blk.shape, (dz, dy, dx))) ** 2)
            c = s + 16.0 * penalty * 4 * (abs(dz) + abs(dy) + abs(dx))
            if best is None or c < best[0]:
                best = (c, (4 * dz, 4 * dy, 4 * dx))
        costs[b] = best[0] / 64.0
        vecs[b] = best[1]
    return vecs, costs


def upsample(ref):
    """The half-voxel grid: voxels at even indices, 8-tap interpolations at odd ones,
    each pass summed in float64 and stored as float32; for 8-bit frames the last pass
    stores 64ths instead (rounded half to even, clamped to int16)."""
    a = ref.astype(np.float64)
    for axis in (2, 1, 0):  # x, then y, then z (float32 rounding makes order matter)
        a = np.moveaxis(a, axis, -1)
        n = a.shape[-1]
        out = np.zeros((*a.shape[:-1], 2 * n - 1))
        out[..., 0::2] = a
        for x in range(n - 1):
            acc = 0.0
            for k, t in enumerate(TAPS):
                acc = acc + t * a[..., min(max(x - 3 + k, 0), n - 1)]
            out[..., 2 * x + 1] = acc
        if axis == 0 and ref.dtype.itemsize == 1:
            out = np.clip(np.rint(out * 64), -32768, 32767) / 64
        else:
            out = out.astype(np.float32).astype(np.float64)
        a = np.moveaxis(out, -1, axis)
    return a


def window(u):
    """The 1-D window at position u = 0..11 of a block's 12-voxel reach."""
    if u < 4:
        return math.sin(math.pi * (u + 0.5) / 8) ** 2
    if u < 8:
        return 1.0
    return math.cos(math.pi * (u - 8 + 0.5) / 8) ** 2


def read(ref, up, p, v):
    """The reference seen from voxel p through the quarter-voxel vector v."""
    if all(c % 4 == 0 for c in v):
        return float(ref[tuple(min(max(a + c // 4, 0), n - 1) for a, c, n in zip(p, v, ref.shape))])
    # position on the half-voxel grid: (4p + v) / 2, between two grid points on each odd
    # axis; a quarter-voxel sample is the mean of the two ends of that box's diagonal
    lo, hi = [], []
    for a, c, n in zip(p, v, up.shape):
        h = 4 * a + c
        lo.append(min(max(h // 2, 0), n - 1))
        hi.append(min(max(h // 2 + h % 2, 0), n - 1))
    return float(np.mean([up[tuple(lo)], up[tuple(hi)]]))


def compensate(mode, fwd, bwd, mean, prev, nxt, windowed=True):
    """The prediction voxel by voxel: every block whose window covers the voxel, weighted
    by the product of 1-D windows, normalised by the weights present."""
    up0, up1 = upsample(prev), upsample(nxt)
    out = np.zeros(prev.shape)
    nb = mode.shape
    for p in np.ndindex(*prev.shape):
        acc, wsum = 0.0, 0.0
        for b in np.ndindex(*nb):
            w = 1.0
            for a in range(3):
                u = p[a] - 8 * b[a] + (2 if windowed else 0)
                if windowed and 0 <= u < 12:
                    w *= window(u)
                elif not windowed and 0 <= u < 8:
                    w *= 1.0
                else:
                    w = 0.0
            if w == 0.0:
                continue
            m = mode[b]
            if m == 3:
                val = mean[b]
            elif m == 0:
                val = read(prev, up0, p, fwd[b])
            elif m == 1:
                val = read(nxt, up1, p, bwd[b])
            else:
                val = 0.5 * (read(prev, up0, p, fwd[b]) + read(nxt, up1, p, bwd[b]))
            acc += w * val
            wsum += w
        out[p] = acc / wsum
    return out


def smooth(pred, k):
    """The prediction filter [k, 64 - 2k, k] / 64 voxel by voxel, x then y then z, each
    neighbour index clamped to the frame."""
    a = np.array(pred, np.float64)
    for axis in (2, 1, 0):
        out = np.empty_like(a)
        n = a.shape[axis]
        for idx in np.ndindex(*a.shape):
            i = idx[axis]
            lo = list(idx)
            hi = list(idx)
            lo[axis] = max(i - 1, 0)
            hi[axis] = min(i + 1, n - 1)
            out[idx] = (64 - 2 * k) / 64 * a[idx] + k / 64 * (a[tuple(lo)] + a[tuple(hi)])
        a = out
    return a


def whole_frame_shift(frame, v):
    """The frame sampled at ``p + v`` as ``formats/animation-1.md`` defines a whole-frame
    shift, computed without transforms: pad by reflection to the odd lengths, then per
    axis a circular sum of the Kaiser-windowed sinc taps, then crop."""
    from volpack.animation import shift

    a = np.asarray(frame, np.float64)
    widths = [(shift.PAD, shift.padded_length(n) - n - shift.PAD) for n in a.shape]
    a = np.pad(a, widths, mode="reflect")
    for axis, d in enumerate(v):
        whole = math.floor(d)
        taps = shift.kernel_taps(d - whole)
        acc = np.zeros_like(a)
        for m, w in zip(range(1 - shift.TAPS, shift.TAPS + 1), taps):
            acc += w * np.roll(a, -(whole + m), axis=axis)  # acc[p] += w a[p + whole + m]
        a = acc
    return a[tuple(slice(shift.PAD, shift.PAD + n) for n in frame.shape)]
