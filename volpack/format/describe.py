"""What a ``.vpk`` holds, read from its header and index alone (no chunk is decoded): the
description ``volpack info`` shows for the brick-coded kinds."""

from __future__ import annotations

from typing import Any, BinaryIO

import numpy as np

from .container import Reader
from .header import raw_nbytes
from .streams import source_size


def describe(source: str | BinaryIO) -> dict[str, Any]:
    """Header, summary, sizes, ratio, chunk sizes and the per-chunk index of a ``.vpk``
    (a path, or a seekable binary file such as :func:`volpack.format.streams.spool` of a
    pipe), as plain JSON types."""
    with Reader(source) as r:
        hdr = r.header
        entries = r.entries
        sizes = np.array([e.nbytes for e in entries], dtype=np.int64)
        errors = np.array([e.error for e in entries], dtype=np.float64)
        raw = raw_nbytes(hdr)
        file_size = source_size(source)
        return {
            "format": "vpk",
            "vpk_version": r.version,
            "path": source if isinstance(source, str) else "-",
            "header": hdr,
            "summary": r.summary,
            "chunks": len(entries),
            "file_nbytes": file_size,
            "payload_nbytes": int(sizes.sum()),
            "raw_nbytes": raw,
            "ratio": raw / max(file_size, 1),
            "chunk_nbytes": {
                "min": int(sizes.min()) if sizes.size else 0,
                "max": int(sizes.max(initial=0)),
                "mean": float(sizes.mean()) if sizes.size else 0.0,
            },
            "max_error": float(errors.max(initial=0.0)),
            "entries": [
                {"t": e.t, "node": e.node, "offset": e.offset, "nbytes": e.nbytes, "error": e.error}
                for e in entries
            ],
        }
