"""volpack's own ``.vpk`` as seen from the file formats: its header only. Decoding and
coding need the stream kinds, a layer above this one (``volpack.read_volume`` and
``volpack.write_volume`` route ``.vpk`` there)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from .common import ReadOptions, header_dict


def read(path: str, opts: ReadOptions) -> Volume:
    from ..format.container import Reader

    with Reader(path):  # reached for a .vpk the stream kinds could not open: say why
        pass
    raise FormatError(
        f"expected a volume file, found the .vpk {path!r}: read it with "
        "volpack.read_volume or volpack.decompress"
    )


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    from ..format.container import Reader

    with Reader(path) as r:
        h = r.header
    try:
        dtype = np.dtype(h["dtype"]).newbyteorder("=")
        return header_dict("vpk", tuple(h["shape"]), dtype, h["spacing"], h["origin"], {})
    except (KeyError, TypeError, ValueError) as e:
        raise FormatError(f"expected a volume header in {path!r}, found {e!r}") from None


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    raise FormatError(
        f"expected a volume file to write, found the .vpk {path!r}: write it with "
        "volpack.write_volume or volpack.compress"
    )
