"""Coefficient coders: a wavelet coefficient array plus its scan to bytes, and back.

Each coder module has ``encode(coeffs, scan) -> bytes`` and ``decode(data, scan, out)``:

``arith``
    significance map + adaptive binary arithmetic coding (best ratio);
``arith2``
    the same model as adaptive multi-symbol rANS (about twice as fast to decode, a
    fraction of a percent larger);
``static``
    the same model with static rANS tables stored per stream (no adaptation; the
    tables cost bytes, and it decodes -1..+17 % faster than ``arith2``);
``auto``
    per stream, ``arith2`` unless ``arith`` is shorter (a byte names the coder): the
    error-bounded codec's default;
``huffman``
    significance map + the fixed prefix code (about ten times faster to decode);
``rle``
    zero runs + the fixed prefix code (for sparse, very lossy coefficients).
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Mapping
from types import ModuleType, SimpleNamespace

# name -> (module of this package, None for the module itself or the fixed code's kind)
_WHERE = {
    "arith": ("arith", None),
    "arith2": ("arith2", None),
    "static": ("static", None),
    "auto": ("choose", None),
    "huffman": ("fixed", "huffman"),
    "rle": ("fixed", "rle"),
}


class _Coders(Mapping):
    """The coders by name, each module imported on first use: a reader needs one coder,
    and importing all of them (``arith2`` alone 30-50 ms) was on the way to a walk's
    first frame."""

    def __init__(self) -> None:
        self._loaded: dict[str, ModuleType | SimpleNamespace] = {}

    def __getitem__(self, name: str):
        coder = self._loaded.get(name)
        if coder is None:
            module, kind = _WHERE[name]
            m = importlib.import_module(f"{__name__}.{module}")
            coder = m if kind is None else SimpleNamespace(
                encode=getattr(m, f"encode_{kind}"), decode=getattr(m, f"decode_{kind}")
            )  # fmt: skip
            self._loaded[name] = coder
        return coder

    def __iter__(self) -> Iterator[str]:
        return iter(_WHERE)

    def __len__(self) -> int:
        return len(_WHERE)


CODERS: Mapping[str, ModuleType | SimpleNamespace] = _Coders()
