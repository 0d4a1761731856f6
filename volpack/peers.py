"""Peer codecs, set up as their authors run them, for the same array volpack codes.

``volpack compare --peers`` and the benchmark scripts (``scripts/bench_lossless.py``,
``scripts/bench_lossy.py``) take their peers from here, so the figures a user gets on
their own data come from the settings the README's tables were measured with:

* lossless: zstd at level 19 (on the bytes shuffled by significance past 8 bits),
  Blosc2 (zstd 9 with bit shuffle), zfp's reversible mode; for integer volumes of up to
  16 bits, the image codecs slice by slice (JPEG-LS, JPEG 2000 and HTJ2K reversible,
  JPEG-XL lossless at chosen efforts; signed voxels shifted to unsigned and back); for
  floats, fpzip and pcodec;
* under an absolute error bound E: zfp in accuracy mode (tolerance E), SZ3 with its
  defaults (absolute bound E) and SPERR in its point-wise error mode (level E), each on
  a float copy of integer data (float32 up to 16 bits, else float64).

Each peer is a :class:`Peer`; :func:`lossless` and :func:`bounded` return the peers
whose packages import, and one line for each that does not. None of these packages is
a dependency of volpack: ``pip install 'volpack[peers]'`` installs them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

JPEGXL_EFFORTS = (7, 9)  # libjxl's default and a slower one; 10 is its highest
SLICE_BITS = 16  # the image codecs take up to 16-bit samples


@dataclasses.dataclass(frozen=True)
class Peer:
    """One peer at one setting: ``encode(array) -> blob`` (bytes, or a list of bytes
    for the slice codecs), ``decode(blob) -> array`` of the input's shape."""

    name: str
    encode: Callable[[np.ndarray], Any]
    decode: Callable[[Any], np.ndarray]
    note: str = ""
    workers: int = 1  # threads over slices (JPEG-LS also runs on two)
    slow: bool = False  # minutes on large volumes (JPEG-XL's highest efforts)


def nbytes(blob: Any) -> int:
    """Size of a peer's output: one buffer, or the sum over a list of slices."""
    if isinstance(blob, (bytes, bytearray, memoryview)):
        return len(blob)
    if isinstance(blob, np.ndarray):
        return int(blob.nbytes)
    return sum(nbytes(b) for b in blob)


def to_unsigned(a: np.ndarray) -> np.ndarray:
    """Signed integers as unsigned of the same width, shifted by ``2**(bits-1)`` (the
    sign bit flipped), for codecs that take unsigned samples only."""
    if a.dtype.kind != "i":
        return a
    u = np.dtype(f"u{a.dtype.itemsize}")
    return a.view(u) ^ u.type(1 << (8 * a.dtype.itemsize - 1))


def from_unsigned(u: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """:func:`to_unsigned` undone."""
    if np.dtype(dtype).kind != "i":
        return u
    return (u ^ u.dtype.type(1 << (8 * u.dtype.itemsize - 1))).view(dtype)


def float_copy(a: np.ndarray) -> np.ndarray:
    """What the lossy peers take: floats as they are, integers as float32 (float64 past
    16 bits, where float32 would round them)."""
    if a.dtype.kind == "f":
        return a
    return a.astype(np.float32 if a.dtype.itemsize <= 2 else np.float64)


_POOLS: dict[int, ThreadPoolExecutor] = {}


def _map(fn: Callable, items: list, workers: int) -> list:
    if workers <= 1:
        return [fn(x) for x in items]
    pool = _POOLS.setdefault(workers, ThreadPoolExecutor(workers))
    return list(pool.map(fn, items))


def _slices(a: np.ndarray) -> list[np.ndarray]:
    """The 2-D slices an image codec codes: the last two axes."""
    return list(a.reshape(-1, *a.shape[-2:]))


# ---------------------------------------------------------------------------------------
# Lossless


def _zstd(dtype: np.dtype, shape: tuple[int, ...]) -> list[Peer]:
    import zstandard

    cctx, dctx = zstandard.ZstdCompressor(level=19), zstandard.ZstdDecompressor()
    size = dtype.itemsize
    if size == 1:
        return [
            Peer(
                "zstd-19",
                lambda a: cctx.compress(np.ascontiguousarray(a)),
                lambda b: np.frombuffer(dctx.decompress(b), dtype).reshape(shape),
                "zstandard, level 19",
            )
        ]

    def decode(b):
        planes = np.frombuffer(dctx.decompress(b), np.uint8).reshape(size, -1)
        return planes.T.copy().view(dtype).reshape(shape)

    return [
        Peer(
            "zstd-19+shuffle",
            lambda a: cctx.compress(
                np.ascontiguousarray(a).view(np.uint8).reshape(-1, size).T.copy()
            ),
            decode,
            "bytes shuffled by significance (numpy), then zstandard level 19",
        )
    ]


def _blosc2(dtype: np.dtype, shape: tuple[int, ...]) -> list[Peer]:
    import blosc2

    cparams = blosc2.CParams(
        codec=blosc2.Codec.ZSTD, clevel=9, filters=[blosc2.Filter.BITSHUFFLE],
        typesize=dtype.itemsize, nthreads=1,
    )  # fmt: skip
    dparams = blosc2.DParams(nthreads=1)
    return [
        Peer(
            "blosc2-zstd9+bitshuffle",
            lambda a: blosc2.compress2(np.ascontiguousarray(a), cparams=cparams),
            lambda b: np.frombuffer(blosc2.decompress2(b, dparams=dparams), dtype).reshape(shape),
            f"python-blosc2 {blosc2.__version__}, typesize = itemsize, 1 thread",
        )
    ]


def _zfp_reversible(dtype: np.dtype, shape: tuple[int, ...]) -> list[Peer]:
    import zfpy

    if dtype.kind == "f":
        return [
            Peer(
                "zfp-rev",
                lambda a: zfpy.compress_numpy(np.ascontiguousarray(a)),
                lambda b: zfpy.decompress_numpy(b).reshape(shape),
                "zfpy, reversible mode",
            )
        ]
    if dtype.itemsize > 4 or dtype == np.uint32:
        raise _Unsupported(f"zfp's reversible mode codes 32-bit integers, found {dtype.name}")
    return [
        Peer(
            "zfp-rev",
            lambda a: zfpy.compress_numpy(a.astype(np.int32)),
            lambda b: zfpy.decompress_numpy(b).astype(dtype).reshape(shape),
            "zfpy, reversible mode on an int32 copy",
        )
    ]


def _fpzip(dtype: np.dtype, shape: tuple[int, ...]) -> list[Peer]:
    import fpzip

    return [
        Peer(
            "fpzip",
            lambda a: fpzip.compress(np.array(a), precision=0),  # it writes into its input
            lambda b: fpzip.decompress(b).reshape(shape),
            "fpzip.compress(precision=0): lossless",
        )
    ]


def _pcodec(dtype: np.dtype, shape: tuple[int, ...]) -> list[Peer]:
    import pcodec
    from pcodec import standalone

    return [
        Peer(
            "pcodec",
            lambda a: standalone.simple_compress(
                np.ascontiguousarray(a).ravel(), pcodec.ChunkConfig()
            ),
            lambda b: standalone.simple_decompress(b).reshape(shape),
            f"pcodec {pcodec.__version__}, standalone, default level",
        )
    ]


class _Unsupported(Exception):
    """A peer that does not take this array (its dtype or shape)."""


def _image_codecs(
    dtype: np.dtype, shape: tuple[int, ...], efforts: Sequence[int], workers: Sequence[int]
) -> list[Peer]:
    import imagecodecs as ic

    if dtype.kind not in "iu" or dtype.itemsize * 8 > SLICE_BITS:
        raise _Unsupported(f"the image codecs take integers of up to 16 bits, found {dtype.name}")
    if len(shape) < 2:
        raise _Unsupported("the image codecs take slices of two axes")
    shift = "; signed voxels shifted by +2**(bits-1) to unsigned and back"
    per = "; coded slice by slice"

    def stack(parts):
        return np.stack(parts).reshape(shape)

    out = [
        Peer(
            "jpegls",
            lambda a, w=w: _map(lambda s: ic.jpegls_encode(to_unsigned(s)), _slices(a), w),
            lambda bs, w=w: stack(_map(lambda b: from_unsigned(ic.jpegls_decode(b), dtype), bs, w)),
            f"CharLS {ic.jpegls_version()}{shift}{per}, {w} thread(s) over slices",
            workers=w,
        )
        for w in workers
    ]
    out.append(
        Peer(
            "jpeg2k",
            lambda a: [
                ic.jpeg2k_encode(s, level=0, reversible=True, numthreads=1) for s in _slices(a)
            ],
            lambda bs: stack(
                [ic.jpeg2k_decode(b, numthreads=1).astype(dtype, copy=False) for b in bs]
            ),
            f"{ic.jpeg2k_version()}, reversible 5/3, the volume's own dtype{per}",
        )
    )
    out.append(
        Peer(
            "htj2k",
            lambda a: [ic.htj2k_encode(to_unsigned(s), reversible=True) for s in _slices(a)],
            lambda bs: stack([from_unsigned(ic.htj2k_decode(b), dtype) for b in bs]),
            f"{ic.htj2k_version()}, reversible{shift}{per}",
        )
    )
    for e in efforts:
        out.append(
            Peer(
                f"jpegxl-e{e}",
                lambda a, e=e: [
                    ic.jpegxl_encode(to_unsigned(s), lossless=True, effort=e, numthreads=1)
                    for s in _slices(a)
                ],
                lambda bs: stack(
                    [from_unsigned(ic.jpegxl_decode(b, numthreads=1), dtype) for b in bs]
                ),
                f"{ic.jpegxl_version()}, lossless, effort {e}{shift}{per}",
                slow=e >= 9,
            )
        )
    return out


def _gather(
    makers: list[Callable[[], list[Peer]]], names: list[str]
) -> tuple[list[Peer], list[str]]:
    peers: list[Peer] = []
    skipped: list[str] = []
    for make, name in zip(makers, names):
        try:
            peers += make()
        except ImportError as exc:
            skipped.append(f"{name}: not installed ({exc.name or exc})")
        except _Unsupported as exc:
            skipped.append(f"{name}: {exc}")
    return peers, skipped


def lossless(
    dtype: Any,
    shape: Sequence[int],
    *,
    jpegxl_efforts: Sequence[int] = JPEGXL_EFFORTS,
    workers: Sequence[int] = (1,),
) -> tuple[list[Peer], list[str]]:
    """The lossless peers for arrays of ``dtype`` and ``shape`` whose packages import, and
    a line for each peer left out (``"jpegls: not installed (imagecodecs)"``).
    ``workers``: the thread counts JPEG-LS runs at (a peer each)."""
    dtype, shape = np.dtype(dtype), tuple(int(s) for s in shape)
    makers = [
        lambda: _zstd(dtype, shape), lambda: _blosc2(dtype, shape),
        lambda: _zfp_reversible(dtype, shape),
    ]  # fmt: skip
    names = ["zstd", "blosc2", "zfp"]
    if dtype.kind == "f":
        makers += [lambda: _fpzip(dtype, shape), lambda: _pcodec(dtype, shape)]
        names += ["fpzip", "pcodec"]
    else:
        makers.append(lambda: _image_codecs(dtype, shape, jpegxl_efforts, workers))
        names.append("JPEG-LS, JPEG 2000, HTJ2K, JPEG-XL (imagecodecs)")
    return _gather(makers, names)


# ---------------------------------------------------------------------------------------
# Under an absolute error bound


def zfp_bounded(x: np.ndarray, e: float) -> bytes:
    """zfp in fixed-accuracy mode: every value within ``e``."""
    import zfpy

    return zfpy.compress_numpy(np.ascontiguousarray(x), tolerance=float(e))


def zfp_decode(blob: bytes) -> np.ndarray:
    import zfpy

    return zfpy.decompress_numpy(blob)


def sz3_encoder(config: str | None = None) -> Callable[[np.ndarray, float], np.ndarray]:
    """An SZ3 encoder at an absolute bound: SZ3's defaults, or the settings of the
    config file ``config`` (pysz's ``loadcfg``). It returns SZ3's output array."""
    from pysz import sz, szConfig, szErrorBoundMode

    def encode(x: np.ndarray, e: float) -> np.ndarray:
        conf = szConfig(x.shape)
        if config is not None:
            conf.loadcfg(config)
        conf.errorBoundMode = szErrorBoundMode.ABS
        conf.absErrorBound = float(e)
        blob, _ratio = sz.compress(np.ascontiguousarray(x), conf)
        return blob

    return encode


def sz3_decode(blob: Any, dtype: Any, shape: Sequence[int]) -> np.ndarray:
    from pysz import sz

    out, _conf = sz.decompress(blob, np.dtype(dtype), tuple(shape))
    return out


# SPERR (imagecodecs 2026.3.6) ends the process with a segmentation fault on a field with
# one value of 1e30 at a bound of 1e-3 or 1e27, of 1e22 at 1e19, of 1e17 at 1e-3, or of
# 1e16 at 1e-4 (session 32: a smooth field with one outlier voxel; 1e20 at 1e17 and 1e16
# at 1e-3 passed). It is not called past ten times below those: the largest magnitude at
# most SPERR_MAX, and at most SPERR_SPAN times the bound.
SPERR_MAX = 1e20
SPERR_SPAN = 1e19


def sperr_bounded(x: np.ndarray, e: float) -> bytes:
    """SPERR in its point-wise error mode (``mode="pwe"``): every value within ``e``."""
    import imagecodecs

    top = float(np.abs(x).max()) if x.size else 0.0
    if top > SPERR_MAX or top > SPERR_SPAN * float(e):
        raise ValueError(
            f"not run: SPERR crashes the process on values as large as {top:.3g} at a bound "
            f"of {float(e):.3g} (largest magnitude above {SPERR_MAX:.0e} or "
            f"{SPERR_SPAN:.0e} times the bound)"
        )
    return imagecodecs.sperr_encode(
        np.ascontiguousarray(_sperr_shape(x)), mode="pwe", level=float(e)
    )


def _sperr_shape(x: np.ndarray) -> np.ndarray:
    """``x`` as SPERR takes it: a volume of one slice as the 2-D image it is. SPERR
    (imagecodecs 2026.3.6) encodes a (1, y, x) array, but its decoder then ends the
    process (a C++ length_error, session 34: any single-slice field); SPERR's 2-D mode
    codes the same image."""
    long = [n for n in x.shape if n > 1]
    if x.ndim == 3 and x.shape[0] == 1 and len(long) == 2:
        return x.reshape(long)
    return x


def sperr_decode(blob: bytes) -> np.ndarray:
    import imagecodecs

    return imagecodecs.sperr_decode(blob)


def bounded(dtype: Any, shape: Sequence[int], max_error: float) -> tuple[list[Peer], list[str]]:
    """The peers that hold every value of an array of ``dtype`` and ``shape`` within
    ``max_error``, each taking :func:`float_copy` of it, and a line for each left out."""
    shape = tuple(int(s) for s in shape)
    e = float(max_error)

    def make_zfp():
        import zfpy  # noqa: F401  (fail here when it is not installed)

        return [
            Peer("zfp", lambda a: zfp_bounded(float_copy(a), e), zfp_decode, "zfpy, tolerance E")
        ]

    def make_sz3():
        enc = sz3_encoder()
        fdt = float_copy(np.zeros(1, dtype)).dtype
        return [
            Peer(
                "sz3", lambda a: enc(float_copy(a), e), lambda b: sz3_decode(b, fdt, shape),
                "pysz, SZ3's defaults, absolute bound E",
            )
        ]  # fmt: skip

    def make_sperr():
        import imagecodecs

        if not 2 <= len(shape) <= 3:
            raise _Unsupported(f"SPERR codes 2-D and 3-D arrays, found {len(shape)} axes")
        if not imagecodecs.SPERR.available:
            raise ImportError(name="imagecodecs with SPERR")
        return [
            Peer(
                "sperr", lambda a: sperr_bounded(float_copy(a), e), lambda b: sperr_decode(b).reshape(shape),
                "imagecodecs sperr_encode(mode='pwe', level=E)",
            )
        ]  # fmt: skip

    return _gather([make_zfp, make_sz3, make_sperr], ["zfp", "SZ3 (pysz)", "SPERR (imagecodecs)"])
