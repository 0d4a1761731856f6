"""The numcodecs codec ``volpack.wavelet`` on its own and inside zarr arrays on disk."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import need, slow_case, smooth_volume

numcodecs = need("numcodecs", "zarr")
zarr = need("zarr", "zarr")

import volpack.numcodecs as vnc  # noqa: E402 (after the skip for a missing zarr extra)
from volpack import api  # noqa: E402
from volpack.numcodecs import VolpackCodec  # noqa: E402

# zarr warns whenever a numcodecs codec is wrapped for a zarr_format=3 array.
ZARR3_WRAPPER_WARNING = "ignore:Numcodecs codecs are not in the Zarr version 3 specification"


def random_array(rng, shape, dtype) -> np.ndarray:
    dtype = np.dtype(dtype)
    if dtype.kind == "b":
        return rng.random(shape) > 0.7
    if dtype.kind == "f":
        return (rng.normal(size=shape) * 50).astype(dtype)
    info = np.iinfo(dtype)
    native = dtype.newbyteorder("=")
    return rng.integers(info.min, info.max, size=shape, dtype=native, endpoint=True).astype(dtype)


def roundtrip(codec: VolpackCodec, a: np.ndarray) -> np.ndarray:
    return codec.decode(codec.encode(a))


# -- config and registry ---------------------------------------------------------------


def test_registered_on_import():
    assert numcodecs.registry.codec_registry[vnc.CODEC_ID] is VolpackCodec
    c = numcodecs.get_codec({"id": "volpack.wavelet", "coder": "huffman", "max_levels": 2})
    assert isinstance(c, VolpackCodec)
    assert (c.coder, c.max_levels, c.wavelet, c.max_error) == ("huffman", 2, "53", None)


@pytest.mark.parametrize(
    "kwargs",
    [
        {},
        {"wavelet": "haar", "coder": "rle", "order": "line", "max_levels": 3},
        {"wavelet": "97m", "coder": "huffman", "max_error": 0.25},
    ],
)
def test_config_round_trip(kwargs):
    c = VolpackCodec(**kwargs)
    config = c.get_config()
    assert config["id"] == "volpack.wavelet"
    again = VolpackCodec.from_config(config)
    assert again == c and again.get_config() == config
    assert numcodecs.get_codec(dict(config)) == c
    assert ("max_error" in config) == ("max_error" in kwargs)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"wavelet": "db4"},
        {"coder": "lzw"},
        {"order": "zigzag"},
        {"max_levels": 17},
        {"max_error": -1},
    ],
)
def test_bad_config_refused(kwargs):
    with pytest.raises(ValueError):
        VolpackCodec(**kwargs)


def test_zero_max_error_is_exact():
    assert VolpackCodec(max_error=0) == VolpackCodec()


# -- encode / decode -------------------------------------------------------------------

SHAPES = [(), (1,), (37,), (5000,), (13, 9), (5, 6, 7), (2, 3, 5, 7), (2, 1, 3, 4, 5)]
DTYPES = ["u1", "i1", "u2", "i2", ">i2", "u4", "i4", "i8", "u8", "f2", "f4", ">f8", "?"]


# float16, float64 and bool compile kernels of their own, and u1 and f4 run the
# default's slowest encoders (predict2, the float blend) here first: the slow set has them
@pytest.mark.parametrize("dtype", [slow_case(d) if d in ("f2", ">f8", "?", "u1", "f4") else d for d in DTYPES])
def test_exact_round_trip(rng, dtype):
    c = VolpackCodec()
    for shape in SHAPES:
        a = random_array(rng, shape, dtype)
        d = roundtrip(c, a)
        assert d.dtype == a.dtype and d.shape == a.shape, (dtype, shape)
        assert np.array_equal(d, a), (dtype, shape)


@pytest.mark.parametrize("coder", ["arith", "arith2", "huffman", "rle"])
def test_smooth_int_compresses_exactly(coder):
    a = smooth_volume((37, 41, 23), np.int16)
    c = VolpackCodec(coder=coder)
    enc = c.encode(a)
    assert len(enc) < a.nbytes / 1.5
    assert np.array_equal(c.decode(enc), a)


def test_decode_from_flat_buffers_and_into_out(rng):
    a = smooth_volume((20, 17, 9), np.uint16)
    c = VolpackCodec(coder="huffman")
    enc = c.encode(a)
    for buf in (enc, bytearray(enc), memoryview(enc), np.frombuffer(enc, np.uint8)):
        assert np.array_equal(c.decode(buf), a)
    out = np.empty_like(a)
    assert c.decode(enc, out=out) is out
    assert np.array_equal(out, a)
    flat = np.zeros(a.size, a.dtype)  # numcodecs hands over flat outputs too
    c.decode(enc, out=flat)
    assert np.array_equal(flat.reshape(a.shape), a)
    # A plain byte string (no shape known) codes as what it is: uint8 bytes.
    raw = rng.integers(0, 9, 1000, dtype=np.uint8).tobytes()
    assert c.decode(c.encode(raw)).tobytes() == raw


def test_special_cases(rng):
    c = VolpackCodec()
    for a in (np.zeros((9, 8, 7), "i4"), np.full((3, 4), 7.5, "f4")):
        assert np.array_equal(roundtrip(c, a), a)
    with pytest.raises(ValueError, match="empty"):
        c.encode(np.zeros((0, 3), "u1"))
    with pytest.raises(TypeError):
        c.encode(np.zeros(4, "c8"))
    with pytest.raises(ValueError, match="numcodecs"):
        c.decode(api.compress_array(np.zeros((2, 2, 2), "u1")))  # a .vpk, not a chunk


@pytest.mark.parametrize("max_error", [1e-3, 0.05, 2.0])
def test_max_error_bounds_float32(rng, max_error):
    a = np.cumsum(rng.normal(size=(30, 33, 19)), axis=0).astype(np.float32)
    a[0, 0, 0], a[1, 2, 3], a[4, 5, 6] = np.nan, np.inf, -np.inf
    c = VolpackCodec(max_error=max_error)
    enc = c.encode(a)
    d = c.decode(enc)
    assert d.dtype == a.dtype and d.shape == a.shape
    ok = np.isfinite(a)
    assert np.array_equal(np.isfinite(d), ok)
    assert np.array_equal(a[~ok], d[~ok], equal_nan=True)
    err = np.abs(d[ok].astype(np.float64) - a[ok].astype(np.float64))
    assert err.max() <= max_error
    if max_error >= 0.05:
        assert len(enc) < a.nbytes / 3  # lossy pays off


@pytest.mark.parametrize("dtype", ["u1", "i2", "u4", "i8", "f8"])
def test_max_error_other_dtypes(rng, dtype):
    a = random_array(rng, (11, 12, 13), dtype)
    d = roundtrip(VolpackCodec(max_error=3), a)
    assert d.dtype == a.dtype
    err = np.abs(d.astype(object) - a.astype(object))  # exact for 64-bit integers
    assert err.max() <= 3


# -- zarr ------------------------------------------------------------------------------


def zarr3_wrapper() -> type:
    from volpack.zarr3 import VolpackWavelet

    return VolpackWavelet


def check_zarr_array(path, a, chunks, make):
    """Write ``a`` to a new zarr array made by ``make``, reopen it and read it back."""
    z = make(path)
    z[:] = a
    del z
    z = zarr.open_array(path, mode="r")
    assert z.shape == a.shape and z.dtype == a.dtype
    assert np.array_equal(z[:], a)
    # A region crossing chunk boundaries and ending in the partial edge chunks.
    sl = tuple(slice(c // 2, None) for c in chunks)
    assert np.array_equal(z[sl], a[sl])
    # Rewrite part of one edge chunk: zarr decodes, patches and re-encodes it.
    z = zarr.open_array(path, mode="r+")
    patch = tuple(slice(n - 3, n) for n in a.shape)
    a = a.copy()
    a[patch] = 7
    z[patch] = a[patch]
    assert np.array_equal(zarr.open_array(path, mode="r")[patch], a[patch])
    return z


@pytest.mark.filterwarnings(ZARR3_WRAPPER_WARNING)
@pytest.mark.parametrize("coder", ["arith", "huffman"])
def test_zarr3_array_on_disk(tmp_path, coder):
    a = smooth_volume((50, 37, 29), np.int16)
    chunks = (16, 16, 16)
    codec = VolpackCodec(coder=coder)

    def make(path):
        return zarr.create_array(
            store=path,
            shape=a.shape,
            chunks=chunks,
            dtype=a.dtype,
            serializer=zarr3_wrapper()(**codec.get_config()),
            compressors=None,
            fill_value=0,
        )

    path = tmp_path / "a.zarr"
    check_zarr_array(path, a, chunks, make)
    meta = zarr.open_array(path, mode="r").metadata
    assert meta.zarr_format == 3
    (c,) = meta.codecs
    assert c.to_dict()["name"] == "volpack.wavelet"
    assert VolpackCodec(**c.to_dict()["configuration"]) == codec


@pytest.mark.parametrize(
    ("dtype", "shape", "chunks"),
    [("u1", (70, 45), (32, 32)), ("i2", (40, 33, 21), (16, 16, 16)), ("f4", (9, 20), (4, 8))],
)
def test_zarr2_array_on_disk(tmp_path, rng, dtype, shape, chunks):
    a = random_array(rng, shape, dtype) if dtype != "i2" else smooth_volume(shape, np.int16)
    codec = VolpackCodec(coder="huffman")

    def make(path):
        return zarr.create_array(
            store=path,
            shape=a.shape,
            chunks=chunks,
            dtype=a.dtype,
            zarr_format=2,
            compressors=[codec],
            fill_value=0,
        )

    path = tmp_path / "a.zarr"
    check_zarr_array(path, a, chunks, make)
    z = zarr.open_array(path, mode="r")
    assert z.metadata.zarr_format == 2
    assert z.metadata.compressor == codec  # rebuilt from .zarray via the numcodecs registry


def test_zarr2_max_error(tmp_path, rng):
    a = np.cumsum(rng.normal(size=(30, 26, 20)), axis=2).astype(np.float32)
    codec = VolpackCodec(max_error=0.01)
    z = zarr.create_array(
        store=tmp_path / "f.zarr",
        shape=a.shape,
        chunks=(16, 16, 16),
        dtype=a.dtype,
        zarr_format=2,
        compressors=[codec],
        fill_value=0,
    )
    z[:] = a
    back = zarr.open_array(tmp_path / "f.zarr", mode="r")[:]
    assert np.abs(back.astype(np.float64) - a).max() <= 0.01


def _entry_points_on_path(tmp_path) -> str:
    """A folder whose dist-info declares pyproject.toml's entry points, for a checkout
    that is not pip-installed (an installed volpack declares them itself)."""
    import importlib.metadata as md
    from pathlib import Path

    groups = ("numcodecs.codecs", "zarr.codecs")
    have = {e.value for g in groups for e in md.entry_points(group=g)}
    if "volpack.numcodecs:VolpackCodec" in have and "volpack.zarr3:VolpackWavelet" in have:
        return ""
    tomllib = pytest.importorskip("tomllib", reason="reading pyproject.toml needs Python 3.11")
    project = tomllib.loads((Path(__file__).parents[2] / "pyproject.toml").read_text())
    eps = project["project"]["entry-points"]
    info = tmp_path / "ep" / "volpack_entry_points-0.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: volpack-entry-points\nVersion: 0\n"
    )
    text = "".join(f"[{g}]\n" + "".join(f"{k} = {v}\n" for k, v in eps[g].items()) for g in groups)
    (info / "entry_points.txt").write_text(text)
    return str(tmp_path / "ep")


def _fresh_python(code: str, extra_path: str) -> None:
    import os
    import subprocess
    import sys

    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (extra_path, env.get("PYTHONPATH", "")) if p)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr


@pytest.mark.slow
@pytest.mark.parametrize("fmt", [2, 3])
def test_fresh_process_finds_the_codec_without_importing_volpack(tmp_path, fmt):
    path = str(tmp_path / "z.zarr")
    a = smooth_volume((9, 10, 11), np.int16)
    np.save(tmp_path / "a.npy", a)
    if fmt == 3:
        from volpack.zarr3 import VolpackWavelet

        z = zarr.create_array(store=path, shape=a.shape, chunks=(8, 8, 8), dtype=a.dtype,
                              serializer=VolpackWavelet(coder="huffman"), compressors=None)  # fmt: skip
    else:
        z = zarr.create_array(store=path, shape=a.shape, chunks=(8, 8, 8), dtype=a.dtype,
                              zarr_format=2, compressors=[VolpackCodec(coder="huffman")])  # fmt: skip
    z[:] = a
    code = (
        "import sys, warnings, numpy as np, zarr, numcodecs\n"
        "warnings.simplefilter('error')\n"  # no warning from a private zarr class
        f"z = zarr.open_array({path!r}, mode='r')\n"
        f"assert (z[:] == np.load({str(tmp_path / 'a.npy')!r})).all()\n"
        "assert numcodecs.get_codec({'id': 'volpack.wavelet'}).coder == 'arith'\n"
    )
    _fresh_python(code, _entry_points_on_path(tmp_path))


@pytest.mark.slow  # compiles the huffman, 9/7-M and lossy paths for these checks alone
def test_numcodecs_test_helpers(tmp_path, monkeypatch):
    """numcodecs' own codec checks: repr, config, buffers, object buffers, stored fixtures
    in C and Fortran order."""
    from numcodecs.tests import common

    monkeypatch.setattr(common, "VolpackCodec", VolpackCodec, raising=False)
    for stmt in ("VolpackCodec()", "VolpackCodec(coder='huffman', max_levels=2)",
                 "VolpackCodec(wavelet='97m', max_error=0.5)"):  # fmt: skip
        common.check_repr(stmt)
    codecs = [
        VolpackCodec(),
        VolpackCodec(coder="huffman", order="line"),
        VolpackCodec(max_error=0.5),
    ]
    arrays = [
        np.arange(1000, dtype="i4"),
        np.linspace(1000, 1001, 1000, dtype="f8"),
        np.random.default_rng(3).integers(0, 200, size=(20, 30, 7)).astype("u1"),
        np.asfortranarray(smooth_volume((12, 9, 7), np.int16)),
        np.asfortranarray(np.arange(600, dtype="u2").reshape(20, 30)),
    ]
    for codec in codecs:
        common.check_config(codec)
        common.check_err_decode_object_buffer(codec)
        common.check_err_encode_object_buffer(codec)
        for a in arrays[2:4]:
            common.check_encode_decode(a, codec, precision=0 if codec.max_error else None)
    monkeypatch.chdir(tmp_path)  # the helper writes its fixtures under ./fixture
    common.check_backwards_compatibility(VolpackCodec.codec_id, arrays, codecs[:2])
    common.check_backwards_compatibility(VolpackCodec.codec_id, arrays, codecs[:2])  # re-read


@pytest.mark.slow
def test_import_registers_the_zarr3_codec(tmp_path):
    import subprocess
    import sys

    code = (
        "import zarr, volpack.zarr3, zarr.registry, numpy as np\n"
        "zarr.registry.get_codec_class('volpack.wavelet')\n"
        f"z = zarr.create_array(store={str(tmp_path / 'z.zarr')!r}, shape=(9, 10, 11), chunks=(8, 8, 8),"
        " dtype='int16', serializer=volpack.zarr3.serializer(), compressors=None)\n"
        "a = (np.arange(990) % 97).astype('int16').reshape(9, 10, 11); z[:] = a\n"
        "assert (zarr.open_array(z.store, mode='r')[:] == a).all()\n"
    )
    r = subprocess.run([sys.executable, "-W", "ignore", "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
