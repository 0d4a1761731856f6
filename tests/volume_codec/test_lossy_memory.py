"""The error-bounded encoder's memory (session 30, results/lossy/mem30): what one brick's
encode allocates at its peak, per voxel, traced by tracemalloc (numpy's arrays; a numba
kernel's own work arrays are not seen), and the wavelet scan caches' byte bound."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from volpack.volume_codec.lossy import BoundedCodec
from volpack.wavelet import packet, sigmap

# A 64^3 smooth float32 field at 1e-3 of its range, its scans already made: 144 bytes a
# voxel before session 30 (the interpolation walks' int64 symbols, every step's
# reconstruction kept by the CDF 9/7 search, whole-array temporaries), 104 after.
PEAK_BYTES_A_VOXEL = 125


def smooth_field(n: int) -> np.ndarray:
    rng = np.random.default_rng(5)
    f = np.fft.fftfreq(n)
    k2 = f[:, None, None] ** 2 + f[None, :, None] ** 2 + f[None, None, :] ** 2
    spec = np.fft.fftn(rng.standard_normal((n, n, n))) * np.where(k2 > 0, k2, 1.0) ** -1.1
    return np.real(np.fft.ifftn(spec)).astype(np.float32)


@pytest.mark.slow
def test_one_brick_encode_peaks_under_its_bytes_a_voxel():
    x = smooth_field(64)
    lo, hi = float(x.min()), float(x.max())
    codec = BoundedCodec.plan(x.dtype, lo, hi, 1e-3 * (hi - lo))
    first = codec.encode_measured(x)  # kernels compiled, this shape's scans made
    tracemalloc.start()
    try:
        again = codec.encode_measured(x)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert again[0] == first[0]
    assert peak / x.size < PEAK_BYTES_A_VOXEL, peak / x.size


def test_the_scan_caches_keep_within_their_bytes(monkeypatch):
    monkeypatch.setattr(sigmap, "SCAN_CACHE_BYTES", 3 * 24**3 * sigmap.SCAN_BYTES_A_VOXEL)
    sigmap.clear_scans()
    shape = (24, 24, 24)
    made = [sigmap.scan(shape, lv, order) for lv in ((3, 3, 3), (2, 2, 2))
            for order in ("dfs", "line", "rows")]  # fmt: skip
    made.append(packet.scan(shape, (3, 2, 1)))
    held = sum(a.nbytes for sc in sigmap._held.values() for a in sc)
    assert 0 < held <= sigmap.SCAN_CACHE_BYTES
    assert packet.scan(shape, (3, 2, 1)) is made[-1]  # the newest kept
    again = sigmap.scan(shape, (3, 3, 3), "dfs")  # let go, made again: the same tables
    assert again is not made[0]
    for a, b in zip(again, made[0]):
        np.testing.assert_array_equal(a, b)
    # one scan larger than the bound is kept while it is the newest
    big = sigmap.scan((40, 40, 40), (3, 3, 3), "line")
    assert sigmap.scan((40, 40, 40), (3, 3, 3), "line") is big
    sigmap.clear_scans()
    assert not sigmap._held
