"""Plumbing shared by the coefficient coders (no coding logic lives here)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import FormatError, OptionError

STATUS = {
    1: "the stream ends before the last coefficient",
    2: "a code names an impossible value",
    3: "it does not end where its length says",
}


def flat_view(a: np.ndarray) -> np.ndarray:
    """A 1-D view of a C-contiguous int32/int64 coefficient array (never a copy)."""
    if a.dtype not in (np.int32, np.int64) or not a.flags.c_contiguous:
        raise OptionError(f"expected a C-contiguous int32/int64 array, found {a.dtype}")
    return a.reshape(-1)


def wide(flat: np.ndarray) -> np.ndarray:
    """``flat`` as int64, copied when int32: each coder's kernels are compiled for int64
    only, one specialisation instead of two (the copy is small beside the coding)."""
    return flat.astype(np.int64, copy=False)


def decoded_into(
    flat: np.ndarray, decode: Callable[[np.ndarray, int], int], coder: str, *, zeroed: bool
) -> None:
    """Run ``decode(into, nmax)`` (a kernel call writing int64 coefficients, returning a
    status) into ``flat``: directly when int64, through an int64 copy when int32 (each
    coder's kernels are compiled for int64 only). ``nmax`` is :func:`max_bits` of
    ``flat`` itself, so int32 output stays within 32-bit values; ``zeroed`` clears the
    target first, for decoders that skip zero subtrees rather than write them."""
    into = flat if flat.dtype == np.int64 else np.empty(flat.size, np.int64)
    if zeroed:
        into[:] = 0
    check_status(decode(into, max_bits(flat)), coder)
    if into is not flat:
        flat[:] = into


def max_bits(flat: np.ndarray) -> int:
    """Largest bit length a mapped coefficient of this dtype can have."""
    return 32 if flat.dtype == np.int32 else 63


def encode_with_retry(
    run: Callable[[np.ndarray], int],
    n: int,
    per_item: tuple[int, int] = (4, 20),
    extra: int = 1024,
    coder: str = "coefficient",
) -> bytes:
    """Run an encoder kernel into a buffer sized for typical data, then the worst case.

    Kernels return the byte count, or -1 when the buffer is too small; most bricks fit
    the first guess, so the worst-case allocation is rarely paid.
    """
    for per in per_item:
        out = np.empty(n * per + extra, dtype=np.uint8)
        used = run(out)
        if used >= 0:
            return out[:used].tobytes()
    raise AssertionError(f"{coder} coder overflowed its worst-case buffer")


def stream_bytes(data: bytes | memoryview, coder: str) -> np.ndarray:
    """The payload as a uint8 array; an empty one is a format error."""
    buf = np.frombuffer(bytes(data), dtype=np.uint8)
    if buf.size < 1:
        raise FormatError(f"{coder} payload: empty stream")
    return buf


def check_status(status: int, coder: str) -> None:
    if status != 0:
        why = STATUS.get(int(status), f"status {status}")
        raise FormatError(f"corrupt {coder}-coded brick: {why}")
