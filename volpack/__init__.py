"""volpack: compress, preprocess and preview volume data.

The package imports nothing heavy at start: numba and the file-format readers load when
a function that needs them is first called, so ``volpack --help`` stays fast.

>>> import numpy as np, volpack
>>> vol = np.arange(4 * 5 * 6, dtype=np.int16).reshape(4, 5, 6)
>>> blob = volpack.compress_array(vol)             # lossless by default
>>> bool((volpack.decompress_array(blob) == vol).all())
True
"""

from __future__ import annotations

__version__ = "0.1.0"

_LAZY = {
    "Volume": "volpack.volume",
    "compress": "volpack.api",
    "decompress": "volpack.api",
    "compress_array": "volpack.api",
    "decompress_array": "volpack.api",
    "info": "volpack.api",
    "open": "volpack.api",
    "read_volume": "volpack.api",
    "write_volume": "volpack.api",
    "VolpackError": "volpack.errors",
    "FormatError": "volpack.errors",
    "ChecksumError": "volpack.errors",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str):
    # PEP 562: load the module that defines a public name only when it is first used.
    try:
        module = _LAZY[name]
    except KeyError:
        raise AttributeError(f"module 'volpack' has no attribute {name!r}") from None
    import importlib

    return getattr(importlib.import_module(module), name)
