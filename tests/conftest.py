"""Shared fixtures: seeded data, the bundled MRI, hypothesis settings for numba code."""

from __future__ import annotations

import io
import tracemalloc

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

# The first example of a property test may compile kernels: no per-example deadline.
settings.register_profile(
    "volpack", deadline=None, max_examples=40, suppress_health_check=[HealthCheck.too_slow]
)
settings.load_profile("volpack")


def need(module: str, extra: str):
    """Import an optional dependency or skip the test, naming the extra that installs it."""
    return pytest.importorskip(
        module, reason=f"{module} is missing: pip install 'volpack[{extra}]' installs it"
    )


def benchmark_volume(name: str) -> np.ndarray:
    """A real volume of the benchmarks (``scripts/datasets.py``, from the data cache that
    ``scripts/fetch_data.py`` fills), or skip the test where it is not fetched or its
    reader is missing."""
    import sys
    from pathlib import Path

    scripts = str(Path(__file__).resolve().parents[1] / "scripts")
    if scripts not in sys.path:
        sys.path.insert(0, scripts)
    datasets = pytest.importorskip("datasets")
    try:
        return datasets.load(name)[0]
    except (FileNotFoundError, ImportError) as e:  # not fetched here, or its reader absent
        pytest.skip(f"{name}: {e}")


# Compiling is most of the fast set, and a kernel both xdist workers first ask for at
# once is compiled twice (64 CPU s in session 17's profile). Work stealing hands each
# worker one half of the list, in order; the renderer's and the mesh coder's tests go at
# the start of the second half, so the second worker first compiles kernels the codec
# tests never use while the first caches the codecs' shared ones.
_OWN_KERNELS = ("tests/render/", "tests/tetra/")


@pytest.hookimpl(trylast=True)
def pytest_collection_modifyitems(config, items):
    own = [i for i in items if i.nodeid.startswith(_OWN_KERNELS)]
    rest = [i for i in items if not i.nodeid.startswith(_OWN_KERNELS)]
    half = min(len(rest), len(items) // 2)
    items[:] = rest[:half] + own + rest[half:]


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261124)


@pytest.fixture(scope="session")
def brain() -> np.ndarray:
    """The bundled head MRI (84, 128, 128) uint8."""
    from volpack.demo import load_demo_volume

    return load_demo_volume().data


def rewrite_header(
    src: bytes, drop: tuple[str, ...] = (), summary: dict | None = None, **fields
) -> bytes:
    """The ``.vpk`` stream ``src`` with header ``fields`` set (a value of None is stored
    as JSON null) and the keys in ``drop`` removed; chunks, their errors and the summary
    kept (or replaced by ``summary``): a damaged or altered header for the readers'
    checks."""
    from volpack.format.container import Reader, Writer

    with Reader(src) as r:
        hdr, summ = dict(r.header), r.summary
        chunks = [(t, n, r.read(t, n), e.error) for (t, n), e in zip(r.keys(), r.entries)]
    hdr.update(fields)
    for k in drop:
        hdr.pop(k, None)
    buf = io.BytesIO()
    w = Writer(buf, hdr)
    for t, n, p, e in chunks:
        w.write(t, n, p, e)
    w.close(summ if summary is None else summary)
    return buf.getvalue()


def smooth_volume(shape, dtype=np.int16, seed=0, noise=3.0) -> np.ndarray:
    """A smooth field plus a little noise: a stand-in for real scans in fast tests."""
    r = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*(np.linspace(0, 3, n) for n in shape), indexing="ij")
    f = 400 * np.sin(z * 1.3 + y) * np.cos(x * 0.7 - y * 0.5) + 600
    f = f + r.normal(0, noise, shape)
    info = np.iinfo(dtype)
    return np.clip(np.rint(f), info.min, info.max).astype(dtype)


def slow_case(value):
    """A parametrize value run in the slow set only: for cases that compile kernel
    variants of their own (another dtype), so the fast set keeps one of each kind."""
    return pytest.param(value, marks=pytest.mark.slow)


def float_specials(cut: np.ndarray) -> np.ndarray:
    """The golden streams' float32 recipe (as ``scripts/make_examples.py`` writes it): a
    cut of the bundled MRI over 3, with NaN, +-Inf, -0.0 and a denormal in place."""
    f = cut.astype(np.float32) / 3
    f[2, 3:6, 4] = np.nan
    f[5, 5, 5] = -np.inf
    f[6, 6, 6] = np.inf
    f[7, 7, 7:9] = -0.0
    f[8, 8, 8] = np.float32(1e-42)
    return f


def traced_peak(fn, *args):
    """``(fn(*args), the peak of the bytes Python and numpy allocated meanwhile)``."""
    tracemalloc.start()
    try:
        got = fn(*args)
        return got, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def flip_bits(codec, good: bytes, a: np.ndarray, rng: np.random.Generator, count: int) -> None:
    """Flip one random bit of the brick payload ``good`` (of ``a``), ``count`` times: each
    damaged payload must raise FormatError or decode to ``a``'s shape and dtype."""
    from volpack.errors import FormatError

    for _ in range(count):
        data = bytearray(good)
        i = int(rng.integers(0, len(data)))
        data[i] ^= 1 << int(rng.integers(0, 8))
        try:
            out = codec.decode(bytes(data), a.shape, a.dtype)
        except FormatError:
            continue
        assert out.shape == a.shape and out.dtype == a.dtype


class Pipe(io.RawIOBase):
    """A readable that refuses to seek and returns short reads, like a pipe."""

    def __init__(self, data: bytes, step: int = 7):
        self._b = io.BytesIO(data)
        self._step = step

    def readable(self):
        return True

    def seekable(self):
        return False

    def readinto(self, m):
        x = self._b.read(min(len(m), self._step))
        m[: len(x)] = x
        return len(x)


def damaged(data: bytes):
    """Every single bit flip of ``data``, every truncation, and one trailing byte."""
    for i in range(len(data)):
        for bit in range(8):
            bad = bytearray(data)
            bad[i] ^= 1 << bit
            yield bytes(bad)
    for n in range(len(data)):
        yield data[:n]
    yield data + b"\x00"
