"""The quantised voxels by the long fitted predictor (formats/lossy-1.md step 20): exact
round trips of the integers, the bound on every voxel through the bounded codec, and
damaged payloads refused. Slow set: the walk kernel compiles here (about 1 CPU s); the
golden stream's test in test_golden.py is the fast one."""

import numpy as np
import pytest

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.format.sections import take_section
from volpack.volume_codec import bounded_longfit as lf
from volpack.volume_codec.lossless import LosslessCodec

pytestmark = pytest.mark.slow
HEAD = 10  # reach, residual type, offset (formats/lossy-1.md step 20)


def band_limited(shape, seed=3):
    """A random field whose wavenumbers stop at a third of the grid's (a spectral
    simulation's de-aliased velocity, in small)."""
    rng = np.random.default_rng(seed)
    k = [np.fft.fftfreq(n) * n for n in shape]
    kz, ky, kx = np.meshgrid(*k, indexing="ij")
    keep = (abs(kz) <= shape[0] / 3) & (abs(ky) <= shape[1] / 3) & (abs(kx) <= shape[2] / 3)
    f = np.zeros(shape, complex)
    f[keep] = rng.normal(size=keep.sum()) + 1j * rng.normal(size=keep.sum())
    f[keep] /= (1 + np.sqrt(kz**2 + ky**2 + kx**2)[keep]) ** 1.5
    return (np.fft.ifftn(f).real * 100).astype(np.float32)


@pytest.mark.parametrize("k", [2, 4, 12])
@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int32])
def test_integers_round_trip(k, dtype):
    """Any quantised brick decodes to itself (faces, edges and the two tiers), whatever
    the residuals' type."""
    rng = np.random.default_rng(k)
    top = min(np.iinfo(dtype).max, 1 << 20)
    q = np.cumsum(rng.integers(-3, 4, (9, 21, 30)), axis=2) % (top + 1)
    q = q.astype(dtype)
    codec = LosslessCodec(tools="predict")
    data = lf.encode(lf.residuals(q, k), codec)
    got = lf.decode(data, q.shape, np.dtype(dtype), codec)
    assert got.dtype == dtype
    np.testing.assert_array_equal(got, q)


def test_walk_matches_numpy_prediction():
    """The walk's residuals against the same sums in numpy (interior tier)."""
    q = np.random.default_rng(1).integers(0, 1000, (14, 16, 18)).astype(np.int64)
    r, w1, _ = lf.residuals(q, 4)
    offs = lf.long_offsets(4)
    z, y, x = 10, 7, 9  # inside the long set's box
    acc = sum(int(w) * int(q[z - dz, y - dy, x - dx]) for w, (dz, dy, dx) in zip(w1, offs))
    assert r[z, y, x] == q[z, y, x] - ((acc + (1 << 15)) >> 16)


@pytest.mark.parametrize("rel", [1e-4, 1e-5])
def test_bound_on_every_voxel(rel):
    """A band-limited field at tight bounds: the encoder picks the long fitted predictor
    (flag bit 3 alone, perhaps with corrections) and every voxel is within E."""
    f = band_limited((40, 40, 40))
    e = rel * float(f.max() - f.min())
    blob = api.compress_array(f, max_error=e)
    with Reader(blob) as r:
        flags = {p[0] for _, _, p in r}
    assert flags <= {8, 10} and flags
    got = api.decompress_array(blob)
    assert np.abs(got.astype(np.float64) - f).max() <= e
    # shorter than the best coding without it
    from volpack.volume_codec import lossy

    old = lossy.LONGFIT_MIN_BITS
    try:
        lossy.LONGFIT_MIN_BITS = 1e9
        assert len(blob) < 0.98 * len(api.compress_array(f, max_error=e))
    finally:
        lossy.LONGFIT_MIN_BITS = old


def _payload(f, e):
    blob = api.compress_array(f, max_error=e)
    with Reader(blob) as r:
        (p,) = [p for _, _, p in r]
    assert p[0] in (8, 10)  # the long fitted predictor
    return bytes(take_section(memoryview(p), 1, "inner")[0])


def test_damaged_payloads_refused():
    f = band_limited((40, 40, 40))
    inner = _payload(f, 1e-5 * float(f.max() - f.min()))
    codec = LosslessCodec()
    qd = np.dtype("uint16")
    assert lf.decode(inner, f.shape, qd, codec).shape == f.shape
    bad = [
        inner[:5],  # header cut
        inner[: HEAD + 10],  # weights cut
        bytes([40]) + inner[1:],  # reach past 16
        inner[:1] + bytes([7]) + inner[2:],  # residual type
        inner[: HEAD] + (1 << 30).to_bytes(4, "little") + inner[HEAD + 4 :],
        inner[:2] + (1 << 40).to_bytes(8, "little", signed=True) + inner[10:],  # out of range
    ]
    for data in bad:
        with pytest.raises(FormatError):
            lf.decode(data, f.shape, qd, codec)
    with pytest.raises(FormatError):
        lf.decode(inner, (40, 40), qd, codec)
