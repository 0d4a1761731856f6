"""Compile every kernel path once (``volpack warmup``), so the on-disk cache is warm."""

from __future__ import annotations

import time

import numpy as np


def warm() -> dict:
    """Run each codec path on tiny bricks of each integer dtype; return what was done."""
    from . import _jit
    from .codec import CODER_NAMES, ORDER_NAMES, WAVELET_NAMES, WaveletCodec

    t0 = time.perf_counter()
    rng = np.random.default_rng(0)
    n = 0
    for dtype in (np.uint8, np.int16, np.int32):
        info = np.iinfo(dtype)
        brick = rng.integers(max(info.min, -1000), min(info.max, 1000), size=(9, 10, 11)).astype(
            dtype
        )
        for wavelet in WAVELET_NAMES:
            for coder in CODER_NAMES:
                for order in ORDER_NAMES:
                    c = WaveletCodec(wavelet=wavelet, coder=coder, order=order)
                    if not np.array_equal(
                        c.decode(c.encode(brick), brick.shape, brick.dtype), brick
                    ):
                        raise AssertionError(f"warm-up round trip failed for {c}")
                    n += 1
    return {
        "kernels": n,
        "seconds": time.perf_counter() - t0,
        "cache_dir": str(_jit.cache_dir()),
        "cache": _jit.CACHE,
    }
