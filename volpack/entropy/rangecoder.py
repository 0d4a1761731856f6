"""The binary range coder as callable steps, for coders that interleave many models.

The steps themselves (:func:`put`, :func:`get`, :func:`push`, :func:`pull`, inline
kernels) live here, and the volume codec (:mod:`volpack.entropy.arith`) inlines them into
its kernels. The mesh coders (connectivity, coordinates, fields) call the wrappers below, with the
coder's state in a small int64 array ``cs``: ``[low, range, position]`` when encoding,
``[code, range, position]`` when decoding (callers may keep more entries after those).
The arithmetic is the same: 12-bit probabilities of a 0 with a 4-bit use count in each
model, a 32-bit range, carries added to the bytes already written, renormalisation by
bytes below ``2^24``, and a first byte of 0 that takes the carry of the first bits. A
decoder reads bytes past the end of its data as 0.

A model adapts by ``1 / 2^rate[use count]`` of its distance to each bit seen;
:func:`put_bit` and :func:`get_bit` use the volume codec's schedule
(:data:`RATE`), :func:`put_decision` and :func:`get_decision`
take the schedule as an argument.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel

PROB_BITS = 12
TOP = 1 << 24
# Each model is one uint16: a 12-bit probability of a 0 above a 4-bit use count k. After
# each use it moves by 1/2**RATE[k] of its distance to the bit seen: fast while young
# (a running average), then settling (bricks are small, so not too slow).
RATE = np.array([1, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5], dtype=np.int64)
STATE_INIT = (1 << (PROB_BITS - 1)) << 4

__all__ = [
    "PROB_BITS",
    "RATE",
    "STATE_INIT",
    "TOP",
    "adapt",
    "adapted",
    "carry",
    "digit",
    "finish_encoder",
    "end_status",
    "finish_stream",
    "open_stream",
    "get",
    "get_bit",
    "get_bits",
    "get_decision",
    "get_held",
    "get_raw",
    "pull",
    "push",
    "put",
    "put_bit",
    "put_bits",
    "put_decision",
    "put_raw",
    "start_decoder",
    "start_encoder",
]


@kernel(inline=True)
def carry(out, pos):
    """Add one to the bytes written so far (the carry out of ``low``)."""
    j = pos - 1
    while out[j] == 0xFF:
        out[j] = 0
        j -= 1
    out[j] += 1


@kernel(inline=True)
def push(out, low, rng, pos):
    """After ``low`` grew and ``rng`` shrank: carry into the bytes written, then shift
    out whole bytes until the range is back above ``2^24``."""
    if low > 0xFFFFFFFF:
        carry(out, pos)
        low &= 0xFFFFFFFF
    while rng < TOP:
        rng <<= 8
        out[pos] = low >> 24
        pos += 1
        low = (low << 8) & 0xFFFFFFFF
    return low, rng, pos


@kernel(inline=True)
def pull(data, code, rng, pos):
    """The decoder's side of :func:`push`: shift in whole bytes (0 past the end)."""
    while rng < TOP:
        rng <<= 8
        byte = np.int64(data[np.uint64(pos)]) if pos < data.size else 0  # (unsigned: no
        code = ((code << 8) | byte) & 0xFFFFFFFF  # test for a wrapped negative index)
        pos += 1
    return code, rng, pos


@kernel(inline=True)
def adapted(p, u, mask, rate):
    """The state of a model (probability ``p`` of a 0, use count ``u``) moved towards
    the bit coded (``mask``: -1 for a 1, 0 for a 0), its use counted."""
    r = rate[u]
    gain = ((1 << PROB_BITS) - p) >> r
    p += gain - ((gain + (p >> r)) & mask)
    return (p << 4) | (u + (u < 15))


@kernel(inline=True)
def adapt(models, k, p, u, mask, rate):
    """:func:`adapted`, stored back into model ``k``."""
    models[k] = adapted(p, u, mask, rate)


@kernel(inline=True)
def put(out, models, k, bit, low, rng, pos, rate):
    """Code one binary decision with the adaptive model ``models[k]``; returns the new
    ``(low, rng, pos)``. Branch-free: the bit is a coin toss to the branch predictor."""
    st = np.int64(models[k])
    p = st >> 4
    u = st & 15
    bound = (rng >> PROB_BITS) * p
    mask = -np.int64(bit)
    low += bound & mask
    rng = bound + ((rng - 2 * bound) & mask)
    adapt(models, k, p, u, mask, rate)
    return push(out, low, rng, pos)


@kernel(inline=True)
def get(data, models, k, code, rng, pos, rate):
    """Decode one binary decision coded by :func:`put`; returns
    ``(bit, code, rng, pos)``."""
    bit, models[k], code, rng, pos = get_held(data, np.int64(models[k]), code, rng, pos, rate)
    return bit, code, rng, pos


@kernel(inline=True)
def get_held(data, st, code, rng, pos, rate):
    """:func:`get` with the model's state ``st`` held by the caller (in a register
    through a run of decisions in one model, rather than a store and a load each);
    returns ``(bit, st, code, rng, pos)``."""
    p = st >> 4
    u = st & 15
    bound = (rng >> PROB_BITS) * p
    bit = np.int64(code >= bound)
    mask = -bit
    code -= bound & mask
    rng = bound + ((rng - 2 * bound) & mask)
    code, rng, pos = pull(data, code, rng, pos)
    return bit, adapted(p, u, mask, rate), code, rng, pos


@kernel(inline=True)
def open_encoder(out):
    """Start encoding: ``(low, rng, pos)``, with a leading zero byte that takes the carry
    of the very first bits (the twin of :func:`open_stream`)."""
    out[0] = 0
    return np.int64(0), np.int64(0xFFFFFFFF), 1


@kernel(inline=True)
def start_encoder(out):
    """Return a fresh encoder state (the first byte takes the carry of the first bits)."""
    cs = np.empty(3, dtype=np.int64)
    cs[0], cs[1], cs[2] = open_encoder(out)
    return cs


@kernel(inline=True)
def finish_stream(out, low, pos):
    """End a stream: the final ``low`` pins the interval. Returns the byte count."""
    for _ in range(4):
        out[pos] = low >> 24
        pos += 1
        low = (low << 8) & 0xFFFFFFFF
    return pos


@kernel(inline=True)
def open_stream(data):
    """Start decoding: ``(code, rng, pos)`` after the leading zero byte and four more."""
    code = np.int64(0)
    pos = 1
    for _ in range(4):
        code = (code << 8) | (np.int64(data[pos]) if pos < data.size else 0)
        pos += 1
    return code, np.int64(0xFFFFFFFF), pos


@kernel(inline=True)
def end_status(data, code, pos):
    """How a decoder stands after its last decision: 0 when it ended where the stream
    does (it read exactly ``data.size`` bytes, the leading byte is the 0 that
    :func:`open_encoder` wrote, and ``code`` is 0: :func:`finish_stream` wrote the
    encoder's final ``low``, which the decoder has subtracted whole), 1 when it read past
    the end, 3 when bytes follow or the stream's first or final bytes are not the
    encoder's. A damaged stream passes all three only by chance (about 2^-32)."""
    if pos > data.size:
        return 1
    if pos < data.size or code != 0 or data[0] != 0:
        return 3
    return 0


@kernel(inline=True)
def finish_encoder(cs, out):
    """Flush the final low (4 bytes) and return the stream length."""
    return finish_stream(out, cs[0], cs[2])


@kernel(inline=True)
def start_decoder(data):
    """Return a decoder state for a stream written from :func:`start_encoder` on."""
    cs = np.empty(3, dtype=np.int64)
    cs[0], cs[1], cs[2] = open_stream(data)
    return cs


@kernel
def put_decision(cs, out, models, k, bit, rate):
    """Code one binary decision with the adaptive model ``models[k]``."""
    cs[0], cs[1], cs[2] = put(out, models, k, bit, cs[0], cs[1], cs[2], rate)


@kernel
def get_decision(cs, data, models, k, rate):
    """Decode one binary decision coded by :func:`put_decision`."""
    bit, cs[0], cs[1], cs[2] = get(data, models, k, cs[0], cs[1], cs[2], rate)
    return bit


@kernel
def put_bit(cs, out, models, k, bit):
    """:func:`put_decision` with the volume codec's adaptation schedule."""
    put_decision(cs, out, models, k, bit, RATE)


@kernel
def get_bit(cs, data, models, k):
    """Decode one binary decision coded by :func:`put_bit`."""
    return get_decision(cs, data, models, k, RATE)


@kernel(inline=True)
def put_bits(out, v, n, low, rng, pos):
    """Code the ``n`` low bits of ``v`` (uint64) at probability one half, top first, up to
    16 at a time (the range splits into ``2^t`` equal parts); returns ``(low, rng, pos)``."""
    while n > 0:
        t = min(n, 16)
        n -= t
        rng >>= t
        low += np.int64((v >> np.uint64(n)) & np.uint64((1 << t) - 1)) * rng
        low, rng, pos = push(out, low, rng, pos)
    return low, rng, pos


@kernel(inline=True)
def digit(code, rng):
    """``code // rng`` for ``0 <= code < 2^32`` and ``rng >= 1`` wherever the quotient is
    below ``2^16`` (a digit of :func:`put_bits`), and ``>= 2^16`` wherever it is: the
    truncated float quotient. (Below ``2^16``, ``code / rng`` is at least ``1 / rng >
    2^-48`` of itself under the next integer, more than a double's rounding moves it;
    from ``2^16`` up the rounding cannot take it under that power of two. A 64-bit
    integer division took several times the latency, on the decoder's one chain.)"""
    return np.int64(np.float64(code) / np.float64(rng))


@kernel(inline=True)
def get_bits(data, v, n, code, rng, pos):
    """Decode ``n`` bits coded by :func:`put_bits`, shifted in below those of ``v``
    (uint64); returns ``(v, code, rng, pos)``. A digit of ``2^t`` or more only comes from
    damage: it is capped at ``2^t - 1`` and the position put past the end, so that the
    caller's end check (:func:`end_status`) refuses the stream."""
    while n > 0:
        t = min(n, 16)
        n -= t
        rng >>= t
        d = digit(code, rng)
        if d >= (1 << t):  # past the last of the 2^t parts: only damage points there,
            d = np.int64((1 << t) - 1)  # so go on with the last part, and put the
            pos = max(pos, data.size + 5)  # position past the end: the end check fails
        code -= d * rng
        v = (v << np.uint64(t)) | np.uint64(d)
        code, rng, pos = pull(data, code, rng, pos)
    return v, code, rng, pos


@kernel
def put_raw(cs, out, v, n):
    """:func:`put_bits` on the state array ``cs``."""
    cs[0], cs[1], cs[2] = put_bits(out, v, n, cs[0], cs[1], cs[2])


@kernel
def get_raw(cs, data, n):
    """Decode ``n`` bits coded by :func:`put_raw` (uint64)."""
    v, cs[0], cs[1], cs[2] = get_bits(data, np.uint64(0), n, cs[0], cs[1], cs[2])
    return v
