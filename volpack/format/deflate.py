"""zstd frames for side data: label-map bricks, lossy masks and corrections, octree level
tables, mesh geometry and order chunks.

Decoders accept a frame of any zstd level; volpack writes every one at :data:`LEVEL`, so
the same input gives the same bytes (``formats/vpk-1.md``, "zstd frames").
"""

from __future__ import annotations

import threading
from collections.abc import Callable

from ..errors import FormatError

LEVEL = 9

_THREAD = threading.local()  # this thread's decompressors, by name


def decompressor(name: str, make: Callable):
    """This thread's zstd decompressor called ``name``, made by ``make()`` on first use.
    Making one costs about 13 us, six times the decompression of a small frame (a brick's
    tables, a header); one must not serve two threads at once, hence one per thread. Each
    use starts a fresh session, so a frame that failed leaves nothing behind."""
    made = _THREAD.__dict__
    d = made.get(name)
    if d is None:
        d = made[name] = make()
    return d


def deflate(data) -> bytes:
    """One zstd frame of ``data`` at :data:`LEVEL`."""
    import zstandard

    return zstandard.ZstdCompressor(level=LEVEL).compress(bytes(data))


def inflate(data, limit: int, what: str, *, exact: bool = False) -> bytes:
    """zstd-decompress ``data`` into at most ``limit`` bytes (exactly ``limit`` with
    ``exact``); a corrupt or mis-sized stream raises FormatError naming ``what``, and a
    false size never allocates more than ``limit``."""
    import zstandard

    try:
        dctx = decompressor("plain", zstandard.ZstdDecompressor)
        raw = dctx.decompress(bytes(data), max_output_size=max(limit, 1))
    except zstandard.ZstdError as e:
        raise FormatError(f"corrupt {what}: {e}") from None
    if exact and len(raw) != limit:
        raise FormatError(
            f"corrupt {what}: expected {limit} bytes after decompression, found {len(raw)}"
        )
    return raw
