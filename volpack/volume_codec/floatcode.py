"""Exact coding of float bricks: sign and exponent by prediction, mantissa by reference.

A float's ordered bit image (:mod:`.floatbits`) splits into a high part (sign and
exponent: 9 bits for float32, 6 for float16) and a low part (the mantissa, flipped for
negative values). Predicting the whole image as one integer fails where a field
crosses zero or changes binade: one step of the float is a leap of the integer. Split,
each part is predictable on its own:

* the high part is predicted by the median of its W, N and U neighbours and the
  residual is coded in a context of how much the neighbours' high parts differ;
* the low part is predicted only from neighbours in the same binade (same high part):
  ``W + N - NW`` when all three are, else the first of W, N, U that is; with none, the
  middle of the range in a context of its own. Its residual is coded in a context of
  the neighbours' low residuals.

Both residuals use the coding of :func:`.predict.put_residual`, adapting at
the faster rates of :mod:`volpack.entropy.rangecoder` (exponent statistics move more). Mantissa bits
below the noise stay costly (they are the data), but zero backgrounds, signs and
exponents cost little. The byte layout is in ``formats/lossless-1.md``.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from ..entropy.common import check_status, encode_with_retry, stream_bytes
from ..entropy.rangecoder import (
    RATE,
    STATE_INIT,
    end_status,
    finish_stream,
    open_encoder,
    open_stream,
)
from .predict import (
    N_MODELS,
    NCTX,
    NO_RESIDUAL,
    activity_class,
    get_residual,
    put_residual,
)

MANTISSA_BITS = {2: 10, 4: 23}  # by itemsize


@kernel(inline=True)
def _high_context(o, eh, i, x, y, z, ny, nx, mb, first):
    """Predicted high part, its context, and the voxel index of each neighbour (-1)."""
    sy = nx
    sz = ny * nx
    jw = i - 1 if x > 0 else -1
    jn = i - sy if y > 0 else -1
    ju = i - sz if z > 0 else -1
    hw = (
        o[jw] >> mb
        if jw >= 0
        else (o[jn] >> mb if jn >= 0 else (o[ju] >> mb if ju >= 0 else first))
    )
    hn = o[jn] >> mb if jn >= 0 else hw
    hu = o[ju] >> mb if ju >= 0 else hw
    # median of three
    pred = max(min(hw, hn), min(max(hw, hn), hu))
    act = abs(hw - hn) + abs(hw - hu) + abs(hn - hu)
    if jw >= 0:
        act += eh[jw]
    if jn >= 0:
        act += eh[jn]
    if ju >= 0:
        act += eh[ju]
    return pred, activity_class(act), jw, jn, ju


@kernel(inline=True)
def _low_context(o, el, i, h, jw, jn, ju, x, nx, mb, mask):
    """Predicted low part of voxel ``i`` whose high part is ``h``, and its context
    (``NCTX - 1`` when no neighbour shares the binade)."""
    lw = jw >= 0 and (o[jw] >> mb) == h
    ln = jn >= 0 and (o[jn] >> mb) == h
    lu = ju >= 0 and (o[ju] >> mb) == h
    jnw = jn - 1 if jn >= 0 and x > 0 else -1
    lnw = jnw >= 0 and (o[jnw] >> mb) == h
    act = np.int64(0)
    if lw and ln and lnw:
        pred = (o[jw] & mask) + (o[jn] & mask) - (o[jnw] & mask)
        pred = min(max(pred, 0), mask)
        act = el[jw] + el[jn]
    elif lw:
        pred = o[jw] & mask
        act = 2 * el[jw]
    elif ln:
        pred = o[jn] & mask
        act = 2 * el[jn]
    elif lu:
        pred = o[ju] & mask
        act = 2 * el[ju]
    else:
        return (mask + 1) >> 1, NCTX - 1
    return pred, min(activity_class(act >> 1), NCTX - 2)


def _workspace(n: int) -> tuple[np.ndarray, ...]:
    """The high and low residual sizes of every voxel and fresh models (the kernels run
    without numba's allocator)."""
    return (
        np.zeros(n, dtype=np.int64),
        np.zeros(n, dtype=np.int64),
        np.full(2 * N_MODELS, STATE_INIT, dtype=np.uint16),
    )


@kernel(nrt=False)
def _encode_kernel(o, shape, mb, out, eh, el, state):
    nz, ny, nx = shape[0], shape[1], shape[2]
    mask = (np.int64(1) << mb) - 1
    first = np.int64(1) << (np.int64(_bits_of(mb)) - mb - 1)  # the high part of +0.0
    cap = out.size
    low, rng, pos = open_encoder(out)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if pos + 64 > cap:
                    return -1
                ph, ch, jw, jn, ju = _high_context(o, eh, i, x, y, z, ny, nx, mb, first)
                h = o[i] >> mb
                low, rng, pos = put_residual(out, state, 0, ch, 0, h - ph, low, rng, pos, RATE)
                pl, cl = _low_context(o, el, i, h, jw, jn, ju, x, nx, mb, mask)
                r = (o[i] & mask) - pl
                low, rng, pos = put_residual(out, state, N_MODELS, cl, 0, r, low, rng, pos, RATE)
                eh[i] = abs(h - ph)
                el[i] = abs(r)
                i += 1
    return finish_stream(out, low, pos)


@kernel(nrt=False)
def _decode_kernel(data, shape, mb, o, eh, el, state):
    """Return 0 on success, 1 when the stream ran short, 2 on an impossible value, 3 when
    it does not end where its length says."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    size = data.size
    mask = (np.int64(1) << mb) - 1
    hmax = (np.int64(1) << (np.int64(_bits_of(mb)) - mb)) - 1
    first = (hmax + 1) >> 1
    code, rng, pos = open_stream(data)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if pos > size + 4:
                    return 1
                ph, ch, jw, jn, ju = _high_context(o, eh, i, x, y, z, ny, nx, mb, first)
                r, code, rng, pos = get_residual(data, state, 0, ch, 0, code, rng, pos, RATE)
                h = ph + r
                if r == NO_RESIDUAL or h < 0 or h > hmax:
                    return 2
                pl, cl = _low_context(o, el, i, h, jw, jn, ju, x, nx, mb, mask)
                r2, code, rng, pos = get_residual(
                    data, state, N_MODELS, cl, 0, code, rng, pos, RATE
                )
                lo = pl + r2
                if r2 == NO_RESIDUAL or lo < 0 or lo > mask:
                    return 2
                o[i] = (h << mb) | lo
                eh[i] = abs(r)
                el[i] = abs(r2)
                i += 1
    return end_status(data, code, pos)


@kernel(inline=True)
def _bits_of(mb):
    """Width of the float whose mantissa has ``mb`` bits."""
    return 32 if mb == 23 else 16


def encode(ordered: np.ndarray, itemsize: int) -> bytes:
    """Code the ordered bit images (int64, 3-D) of floats of ``itemsize`` bytes."""
    o = np.ascontiguousarray(ordered, dtype=np.int64)
    if o.ndim != 3 or itemsize not in MANTISSA_BITS:
        raise ValueError(f"expected a 3-D array of 2- or 4-byte floats, found {o.shape}")
    shape = np.array(o.shape, dtype=np.int64)
    flat = o.reshape(-1)
    mb = np.int64(MANTISSA_BITS[itemsize])
    return encode_with_retry(
        lambda out: _encode_kernel(flat, shape, mb, out, *_workspace(flat.size)),
        flat.size,
        (8, 24),
        coder="float",
    )


def decode(data: bytes | memoryview, shape: tuple[int, int, int], itemsize: int) -> np.ndarray:
    """Decode :func:`encode`'s bytes into the ordered images (int64) of ``shape``."""
    buf = stream_bytes(data, "float")
    o = np.empty(int(np.prod(shape)), dtype=np.int64)
    shp = np.array(shape, dtype=np.int64)
    status = _decode_kernel(buf, shp, np.int64(MANTISSA_BITS[itemsize]), o, *_workspace(o.size))
    check_status(status, "float")
    return o.reshape(shape)
