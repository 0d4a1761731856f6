"""Adaptive arithmetic coding of integer residuals: 4-bit packages and scaled residuals.

Two codes share one binary range coder here.

**Packages** (seed-004 §10.9 step 2; the point and cell data use them). A residual ``r``
(int64, wrapping) is mapped to ``u = 2r`` or ``-2r - 1`` and cut into 4-bit packages
(nibbles). The coder sends

1. ``n``, the number of significant packages (0 for a zero residual), as a 5-level
   binary tree of adaptive decisions in the context ``(class, ctx)`` chosen by the
   caller (attributes: the component and the previous residual's size);
2. the leading package (1..15) as a 4-level tree with models per ``(class, n)``;
3. the other packages, top down, as 4-level trees with models per ``(class, n, place)``:
   each package position has its own adaptive frequencies, as in the thesis.

**Scaled residuals** (:func:`put_scaled`; the vertex coordinates use them). When the
caller can estimate a residual's size, its bit length is coded as steps from that
estimate, then the sign, two adaptive bits below the leading one, and the rest raw: the
low bits of a well predicted coordinate are noise, and learning frequencies for them
only costs bits on small meshes.

The binary decisions and raw bits go through :mod:`volpack.entropy.rangecoder` (the
range coder of :mod:`volpack.entropy.arith` with its state in a 3-element array), which
the connectivity coder shares.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel, leading_zeros
from ..entropy.rangecoder import (  # noqa: F401 - the primitives the coders here build on
    STATE_INIT,
    end_status,
    finish_encoder,
    get_bit,
    get_raw,
    put_bit,
    put_raw,
    start_decoder,
    start_encoder,
)
from ..errors import FormatError

MAX_PACKAGES = 16  # 64 bits
N_COUNT = 32  # tree nodes for the package count (5 levels)
STATUS = {
    1: "the stream ends early",
    2: "a residual is longer than its field",
    3: "it does not end where its length says",
}


def n_models(n_cls: int, n_ctx: int) -> int:
    """Size of the model array for ``n_cls`` classes and ``n_ctx`` count contexts."""
    return n_cls * (n_ctx * N_COUNT + 17 * 16 + 17 * 16 * 16)


def new_models(n_cls: int, n_ctx: int) -> np.ndarray:
    """Fresh adaptive models (every probability one half, use count zero)."""
    return np.full(n_models(n_cls, n_ctx), STATE_INIT, dtype=np.uint16)


def packages_for_bits(bits: int) -> int:
    """Packages needed for a mapped residual of a ``bits``-bit field (sign included)."""
    return max(1, min(MAX_PACKAGES, -(-(bits + 1) // 4)))


def check_status(status: int, what: str) -> None:
    """Raise :class:`FormatError` for a decoder's non-zero status."""
    if status != 0:
        raise FormatError(f"corrupt {what} stream: {STATUS.get(int(status), status)}")


def worst_case_bytes(n_values: int, width: int) -> int:
    """Bytes a stream of ``n_values`` residuals can take at most (12 bits a decision)."""
    return (n_values * (5 + 4 * width) * 12) // 8 + 64


def ordered_bits(x: np.ndarray) -> np.ndarray:
    """Floats (2, 4 or 8 bytes) to int64 keeping their order (an involution on bits)."""
    w = x.dtype.itemsize * 8
    b = x.view(f"<i{x.dtype.itemsize}" if x.dtype.byteorder != ">" else f">i{x.dtype.itemsize}")
    b = b.astype(np.int64)
    return b ^ ((b >> (w - 1)) & np.int64((1 << (w - 1)) - 1))


def from_ordered_bits(v: np.ndarray, dtype) -> np.ndarray:
    """Inverse of :func:`ordered_bits`."""
    dt = np.dtype(dtype)
    w = dt.itemsize * 8
    b = v ^ ((v >> (w - 1)) & np.int64((1 << (w - 1)) - 1))
    return b.astype(f"i{dt.itemsize}").view(dt.newbyteorder("=")).astype(dt)


# --- kernels (numba) --------------------------------------------------------------------
# The coder state ``cs`` and the binary primitives are :mod:`volpack.entropy.rangecoder`'s.


@kernel(inline=True)
def _layout(n_ctx, cls):
    """Offsets of the count, leading-package and other-package models of a class."""
    per = n_ctx * N_COUNT + 17 * 16 + 17 * 16 * 16
    base = cls * per
    return base, base + n_ctx * N_COUNT, base + n_ctx * N_COUNT + 17 * 16


@kernel
def put_residual(cs, out, models, n_ctx, cls, ctx, r):
    """Code the int64 residual ``r``; return its package count (a context for later)."""
    u = np.uint64(r << 1) ^ np.uint64(r >> 63)
    n = 0
    t = u
    while t != 0:
        n += 1
        t >>= np.uint64(4)
    cnt, lead, rest = _layout(n_ctx, cls)
    node = 1
    for lv in range(4, -1, -1):  # the count, 5 decisions down a binary tree
        b = (n >> lv) & 1
        put_bit(cs, out, models, cnt + ctx * N_COUNT + node, b)
        node = 2 * node + b
    for j in range(n - 1, -1, -1):
        nib = np.int64((u >> np.uint64(4 * j)) & np.uint64(15))
        base = lead + n * 16 if j == n - 1 else rest + (n * 16 + j) * 16
        node = 1
        for lv in range(3, -1, -1):
            b = (nib >> lv) & 1
            put_bit(cs, out, models, base + node, b)
            node = 2 * node + b
    return n


@kernel
def get_residual(cs, data, models, n_ctx, cls, ctx, width):
    """Decode a residual coded by :func:`put_residual`; return ``(r, n, ok)``."""
    cnt, lead, rest = _layout(n_ctx, cls)
    node = 1
    for _ in range(5):
        node = 2 * node + get_bit(cs, data, models, cnt + ctx * N_COUNT + node)
    n = node - 32
    if n > width:
        return np.int64(0), n, False
    u = np.uint64(0)
    for j in range(n - 1, -1, -1):
        base = lead + n * 16 if j == n - 1 else rest + (n * 16 + j) * 16
        node = 1
        for _ in range(4):
            node = 2 * node + get_bit(cs, data, models, base + node)
        u = (u << np.uint64(4)) | np.uint64(node - 16)
    r = np.int64(u >> np.uint64(1)) ^ -np.int64(u & np.uint64(1))
    return r, n, True


# --- scaled residuals: bit length from an estimate, two adaptive bits, the rest raw ---------
# A residual whose size the caller can estimate (vertex coordinates: from the local edge
# length) is better served by coding its bit length relative to that estimate than by
# 4-bit packages: the packages below the leading one are nearly uniform, and learning
# their frequencies costs bits on small meshes.

SCALED_SET = 64  # models per context set of :func:`put_scaled`
_UP, _DOWN, _MANT, _SIGN = 1, 17, 33, 63  # offsets within a set (0: "above the estimate?")
MANT_ADAPTIVE = 2  # bits below the leading one with adaptive probabilities
# at most 68 adaptive decisions (12 bits each at worst) and 64 raw bits, plus slack
SCALED_MAX_BYTES = (68 * 12 + 64) // 8 + 2


def scaled_worst_case_bytes(n_values: int) -> int:
    """Bytes a stream of ``n_values`` scaled residuals can take at most."""
    return n_values * SCALED_MAX_BYTES + 64


@kernel(inline=True)
def _mant_ctx(nb, q):
    """Mantissa model row: how far the bit length landed from the estimate (5 rows)."""
    return min(max(nb - q + 2, 0), 4)


@kernel
def put_scaled(cs, out, models, base, q, r):
    """Code the int64 residual ``r`` given the estimate ``q`` of its bit length.

    ``models[base:base + SCALED_SET]`` is the context set; ``q`` is clamped to 0..64.
    The bit length ``nb`` of
    ``|r|`` is coded as one decision (``nb > q``?) and then steps up or down from ``q``,
    each step with its own model; then the sign, the ``MANT_ADAPTIVE`` bits below the
    leading one (models per distance from the estimate and the bits so far), and the
    remaining low bits raw.
    """
    q = min(max(q, 0), 64)
    a = np.uint64(-r) if r < 0 else np.uint64(r)
    nb = 64 - np.int64(leading_zeros(a))
    up = nb > q
    put_bit(cs, out, models, base, np.int64(up))
    if up:
        j = q + 1
        while j < 64:  # is it longer than j?
            put_bit(cs, out, models, base + _UP + min(j - q - 1, 15), np.int64(nb > j))
            if nb == j:
                break
            j += 1
    else:
        j = q
        while j > 0:  # is it shorter than j?
            put_bit(cs, out, models, base + _DOWN + min(q - j, 15), np.int64(nb < j))
            if nb == j:
                break
            j -= 1
    if nb == 0:
        return
    put_bit(cs, out, models, base + _SIGN, np.int64(r < 0))
    nm = min(nb - 1, MANT_ADAPTIVE)
    row = base + _MANT + 6 * _mant_ctx(nb, q)
    node = 1
    for jm in range(nm):
        b = np.int64((a >> np.uint64(nb - 2 - jm)) & np.uint64(1))
        put_bit(cs, out, models, row + node - 1, b)
        node = 2 * node + b
    put_raw(cs, out, a, nb - 1 - nm)


@kernel
def get_scaled(cs, data, models, base, q, nmax):
    """Decode a residual coded by :func:`put_scaled`; return ``(r, ok)`` (``ok`` is
    false when the bit length exceeds ``nmax``)."""
    q = min(max(q, 0), 64)
    up = get_bit(cs, data, models, base)
    if up:
        nb = q + 1
        while nb < 64:
            if get_bit(cs, data, models, base + _UP + min(nb - q - 1, 15)) == 0:
                break
            nb += 1
            if nb > nmax:
                return np.int64(0), False
    else:
        nb = q
        while nb > 0:
            if get_bit(cs, data, models, base + _DOWN + min(q - nb, 15)) == 0:
                break
            nb -= 1
    if nb > nmax:
        return np.int64(0), False
    if nb == 0:
        return np.int64(0), True
    neg = get_bit(cs, data, models, base + _SIGN)
    nm = min(nb - 1, MANT_ADAPTIVE)
    row = base + _MANT + 6 * _mant_ctx(nb, q)
    node = 1
    for _ in range(nm):
        node = 2 * node + get_bit(cs, data, models, row + node - 1)
    a = (np.uint64(node) << np.uint64(nb - 1 - nm)) | get_raw(cs, data, nb - 1 - nm)
    r = np.int64(a)
    return (-r if neg else r), True
