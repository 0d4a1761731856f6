"""zstd frames for side data: label-map bricks, lossy masks and corrections, octree level
tables, mesh geometry and order chunks.

Decoders accept a frame of any zstd level; volpack writes every one at :data:`LEVEL`, so
the same input gives the same bytes (``formats/vpk-1.md``, "zstd frames").
"""

from __future__ import annotations

from ..errors import FormatError

LEVEL = 9


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
        raw = zstandard.ZstdDecompressor().decompress(bytes(data), max_output_size=max(limit, 1))
    except zstandard.ZstdError as e:
        raise FormatError(f"corrupt {what}: {e}") from None
    if exact and len(raw) != limit:
        raise FormatError(
            f"corrupt {what}: expected {limit} bytes after decompression, found {len(raw)}"
        )
    return raw
