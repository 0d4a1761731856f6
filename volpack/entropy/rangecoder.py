"""The binary range coder as callable steps, for coders that interleave many models.

The volume codec (:mod:`volpack.entropy.arith`) inlines the same steps (``_put``,
``_get``, ``_push``, ``_pull``) into its kernels. The mesh coders (connectivity, coordinates, fields) call these instead, with the
coder's state in a small int64 array ``cs``: ``[low, range, position]`` when encoding,
``[code, range, position]`` when decoding (callers may keep more entries after those).
The arithmetic is the same: 12-bit probabilities of a 0 with a 4-bit use count in each
model, a 32-bit range, carries added to the bytes already written, renormalisation by
bytes below ``2^24``, and a first byte of 0 that takes the carry of the first bits. A
decoder reads bytes past the end of its data as 0.

A model adapts by ``1 / 2^rate[use count]`` of its distance to each bit seen;
:func:`put_bit` and :func:`get_bit` use the volume codec's schedule
(:data:`volpack.entropy.arith.RATE`), :func:`put_decision` and :func:`get_decision`
take the schedule as an argument.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from .arith import RATE, _get, _pull, _push, _put

__all__ = [
    "finish_encoder",
    "get_bit",
    "get_decision",
    "get_raw",
    "put_bit",
    "put_decision",
    "put_raw",
    "start_decoder",
    "start_encoder",
]


@kernel(inline=True)
def start_encoder(out):
    """Return a fresh encoder state (the first byte takes the carry of the first bits)."""
    out[0] = 0
    cs = np.empty(3, dtype=np.int64)
    cs[0] = 0
    cs[1] = 0xFFFFFFFF
    cs[2] = 1
    return cs


@kernel(inline=True)
def finish_encoder(cs, out):
    """Flush the final low (4 bytes) and return the stream length."""
    low = cs[0]
    pos = cs[2]
    for _ in range(4):
        out[pos] = low >> 24
        pos += 1
        low = (low << 8) & 0xFFFFFFFF
    return pos


@kernel(inline=True)
def start_decoder(data):
    """Return a decoder state for a stream written from :func:`start_encoder` on."""
    cs = np.empty(3, dtype=np.int64)
    code = np.int64(0)
    pos = 1
    for _ in range(4):
        code = (code << 8) | (np.int64(data[pos]) if pos < data.size else 0)
        pos += 1
    cs[0] = code
    cs[1] = 0xFFFFFFFF
    cs[2] = pos
    return cs


@kernel
def put_decision(cs, out, models, k, bit, rate):
    """Code one binary decision with the adaptive model ``models[k]``."""
    cs[0], cs[1], cs[2] = _put(out, models, k, bit, cs[0], cs[1], cs[2], rate)


@kernel
def get_decision(cs, data, models, k, rate):
    """Decode one binary decision coded by :func:`put_decision`."""
    bit, cs[0], cs[1], cs[2] = _get(data, models, k, cs[0], cs[1], cs[2], rate)
    return bit


@kernel
def put_bit(cs, out, models, k, bit):
    """:func:`put_decision` with the volume codec's adaptation schedule."""
    put_decision(cs, out, models, k, bit, RATE)


@kernel
def get_bit(cs, data, models, k):
    """Decode one binary decision coded by :func:`put_bit`."""
    return get_decision(cs, data, models, k, RATE)


@kernel
def put_raw(cs, out, v, n):
    """Code the ``n`` low bits of ``v`` (uint64) at probability one half, top first,
    up to 16 at a time (the range splits into ``2^t`` equal parts)."""
    low = cs[0]
    rng = cs[1]
    pos = cs[2]
    while n > 0:
        t = min(n, 16)
        n -= t
        rng >>= t
        low += np.int64((v >> np.uint64(n)) & np.uint64((1 << t) - 1)) * rng
        low, rng, pos = _push(out, low, rng, pos)
    cs[0] = low
    cs[1] = rng
    cs[2] = pos


@kernel
def get_raw(cs, data, n):
    """Decode ``n`` bits coded by :func:`put_raw` (uint64)."""
    code = cs[0]
    rng = cs[1]
    pos = cs[2]
    v = np.uint64(0)
    while n > 0:
        t = min(n, 16)
        n -= t
        rng >>= t
        d = min(code // rng, np.int64((1 << t) - 1))
        code -= d * rng
        v = (v << np.uint64(t)) | np.uint64(d)
        code, rng, pos = _pull(data, code, rng, pos)
    cs[0] = code
    cs[1] = rng
    cs[2] = pos
    return v
