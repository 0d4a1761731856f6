"""Slow, obvious references for the octree: the level pyramid by Python lifting of each
block, node errors by looping over every full-resolution voxel, and trilinear
upsampling of a whole level."""

import itertools
import math

import numpy as np
from naive import wavelet_forward


def pyramid(a, k, wavelet, depth):
    """``[A_0, ..., A_depth]`` and the detail blocks ``{(L, b): coefficients}``."""
    levels = [np.asarray(a, dtype=np.int64)]
    details = {}
    for lv in range(1, depth + 1):
        prev = levels[-1]
        n = prev.shape
        low = np.zeros([(v + 1) // 2 for v in n], np.int64)
        for b in itertools.product(*(range(math.ceil(v / (2 * k))) for v in n)):
            box = tuple(slice(2 * k * i, min(2 * k * (i + 1), v)) for i, v in zip(b, n))
            blk = prev[box]
            lift = tuple(1 if v >= 2 else 0 for v in blk.shape)
            c = wavelet_forward(blk, lift, wavelet)
            ls = tuple((v + 1) // 2 for v in blk.shape)
            low[tuple(slice(k * i, k * i + v) for i, v in zip(b, ls))] = c[
                tuple(slice(0, v) for v in ls)
            ]
            d = c.copy()
            d[tuple(slice(0, v) for v in ls)] = 0
            details[(lv, b)] = (d, lift)
        levels.append(low)
    return levels, details


def coefficient_scale(shape, lift):
    """Orthonormal factor of each coefficient of a one-level block: sqrt 2 per low-pass
    axis, 1/sqrt 2 per high-pass axis, 1 on axes that were not lifted."""
    out = np.ones(shape)
    for ax, (n, lv) in enumerate(zip(shape, lift)):
        if not lv:
            continue
        f = np.full(n, 2**-0.5)
        f[: (n + 1) // 2] = 2**0.5
        sh = [1, 1, 1]
        sh[ax] = n
        out = out * f.reshape(sh)
    return out


def subtree_energy(details, lv, b, unit=1.0):
    """Sum of squared normalised details of node (lv, b) and every node below it."""
    total = 0.0
    for (l2, b2), (d, lift) in details.items():
        if l2 > lv:
            continue
        f = 1 << (lv - l2)
        if tuple(i // f for i in b2) != tuple(b):
            continue
        s = coefficient_scale(d.shape, lift) * unit * 2.0 ** (1.5 * (l2 - 1))
        total += float(np.sum((d * s) ** 2))
    return total


def max_deviation(x, values, lv, k, b):
    """max |x[p] - values[p >> lv]| over the full-resolution voxels p of node (lv, b)."""
    f = 1 << lv
    worst = 0.0
    for p in itertools.product(
        *(range(k * i * f, min(k * (i + 1) * f, n)) for i, n in zip(b, x.shape))
    ):
        q = tuple(v // f for v in p)
        worst = max(worst, abs(float(x[p]) - float(values[q])))
    return worst


def upsample_linear(a, f, shape):
    """Trilinear resampling of a whole level ``a`` (factor ``f``) onto ``shape``, with
    voxel centres at ``(i + 0.5) / f - 0.5`` and edges clamped."""
    out = np.zeros(shape)
    for p in itertools.product(*(range(n) for n in shape)):
        acc = 0.0
        pos = [(i + 0.5) / f - 0.5 for i in p]
        j0 = [min(max(int(math.floor(q)), 0), n - 1) for q, n in zip(pos, a.shape)]
        w = [min(max(q - j, 0.0), 1.0) for q, j in zip(pos, j0)]
        for corner in itertools.product((0, 1), repeat=3):
            idx = tuple(min(j + c, n - 1) for j, c, n in zip(j0, corner, a.shape))
            wt = math.prod(ww if c else 1 - ww for ww, c in zip(w, corner))
            acc += wt * float(a[idx])
        out[p] = acc
    return out


def tf_range(points, lo, hi):
    """Component-wise (min, max) of a piecewise-linear RGBA transfer function over
    ``[lo, hi]``, by sampling it densely plus its ends and control points."""
    lo, hi = min(lo, hi), max(lo, hi)
    pts = np.asarray(points, np.float64)
    xs = np.concatenate([np.linspace(lo, hi, 257), pts[(pts[:, 0] >= lo) & (pts[:, 0] <= hi), 0]])
    rgba = np.stack([np.interp(xs, pts[:, 0], pts[:, 1 + c]) for c in range(4)], axis=1)
    return rgba.min(axis=0), rgba.max(axis=0)


def tf_node_error(points, row, diag, bins=8):
    """The eq.-2.7 error bound of one node-table row, bin by bin in plain floats (the
    optical depths searched over a fine grid of segment lengths for the opacity term)."""
    vmin, vmax = float(row["vmin"]), float(row["vmax"])
    width = (vmax - vmin) / bins
    worst = 0.0
    ds = np.linspace(0.0, diag, 4001)
    for j in range(bins):
        dn, dp = float(row["hist"][j, 0]), float(row["hist"][j, 1])
        if dn == 0.0 and dp == 0.0:
            continue
        cmin, cmax = tf_range(points, vmin + j * width + dn, vmin + (j + 1) * width + dp)
        dmin = -math.log1p(-min(float(cmin[3]), 1 - 1e-12))
        dmax = -math.log1p(-min(float(cmax[3]), 1 - 1e-12))
        err_o = float(np.max(np.exp(-ds * dmin) - np.exp(-ds * dmax)))
        err_o_diag = math.exp(-diag * dmin) - math.exp(-diag * dmax)
        err_c = sum((cmax[c] - cmin[c]) * (1 - math.exp(-diag * dmax)) + cmin[c] * err_o_diag
                    for c in range(3))  # fmt: skip
        worst = max(worst, err_o + err_c)
    return worst
