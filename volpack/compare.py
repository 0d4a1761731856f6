"""Compress, decompress and measure in one call (as zfp's ``-s`` and SZ3's ``-a`` do),
or measure one volume against another.

:func:`compare` holds the stream in memory; the voxels come back from the decoder and are
compared with the input on every voxel: ratio (of the whole stream, as ``volpack info``
counts), maximum error, PSNR, RMSE, and encode and decode speed in MB/s of raw voxels.
:func:`measure` compares two volumes already decoded (volpack's or another codec's).
"""

from __future__ import annotations

import io
import time
from typing import Any

import numpy as np

from .volume import Volume


def compare(vol: Volume | np.ndarray, *, warm: bool = False, **options: Any) -> dict[str, Any]:
    """Code ``vol`` with ``options`` (as for :func:`volpack.api.compress` of a volume),
    decode it and return ``ratio``, ``file_nbytes``, ``raw_nbytes``, ``max_error``,
    ``psnr``, ``rmse``, ``lossless``, ``enc_mb_s``, ``dec_mb_s``, ``enc_seconds``,
    ``dec_seconds`` and the encoder's own report under ``compress``. The first decode
    of a process also loads its kernels; with ``warm`` the stream is decoded once more
    and ``dec_seconds_warm``, ``dec_mb_s_warm`` time that second decode (what a peer
    compiled ahead of time is measured against)."""
    from . import api, metrics

    vol = vol if isinstance(vol, Volume) else Volume(np.asarray(vol))
    buf = io.BytesIO()
    t0 = time.perf_counter()
    stats = api.compress(vol, buf, kind="volume", **options)
    enc = time.perf_counter() - t0
    blob = buf.getvalue()
    t0 = time.perf_counter()
    back = api.decompress(blob, workers=options.get("workers", 1))
    dec = time.perf_counter() - t0
    warm_seconds = None
    if warm:
        t0 = time.perf_counter()
        api.decompress(blob, workers=options.get("workers", 1))
        warm_seconds = time.perf_counter() - t0
    left_out = vol.mask  # metrics leave out the voxels a mask marks True
    a, b = vol.data, back.data
    if a.dtype.kind == "f":  # NaN/Inf come back exactly; the error is over finite voxels
        finite = np.isfinite(a)
        if not np.array_equal(finite, np.isfinite(b)) or not np.array_equal(
            a[~finite], b[~finite], equal_nan=True
        ):
            raise AssertionError("the decoder did not give back the NaN/Inf voxels exactly")
        left_out = ~finite if left_out is None else left_out | ~finite
        filled = _fill_voxels(vol, options)
        if filled is not None:  # as NaN: back bit for bit, and out of the error and peak
            if not np.array_equal(a[filled].view(np.uint8), b[filled].view(np.uint8)):
                raise AssertionError("the decoder did not give back the fill voxels exactly")
            left_out = left_out | filled
    m = metrics.summary(a, b, len(blob), mask=left_out)
    out = {
        "shape": list(vol.shape),
        "dtype": vol.dtype.name,
        "raw_nbytes": int(vol.nbytes),
        "file_nbytes": len(blob),
        "ratio": m["ratio"],
        "bpv": m["bpv"],
        "max_error": m["max_error"],
        "psnr": m["psnr"],
        "rmse": m["rmse"],
        "lossless": bool(np.array_equal(a, b, equal_nan=a.dtype.kind == "f")),
        "enc_seconds": enc,
        "dec_seconds": dec,
        "enc_mb_s": metrics.throughput(vol.nbytes, enc),
        "dec_mb_s": metrics.throughput(vol.nbytes, dec),
        "compress": stats,
    }
    if warm_seconds is not None:
        out["dec_seconds_warm"] = warm_seconds
        out["dec_mb_s_warm"] = metrics.throughput(vol.nbytes, warm_seconds)
    return out


def _fill_voxels(vol: Volume, options: dict[str, Any]) -> np.ndarray | None:
    """Where a float volume holds the fill value the coding was given (``fill_value``,
    else the one its source declares, as the encoder takes it under a lossy setting):
    the encoder keeps those voxels exactly and leaves them out of its bound, its value
    range and its PSNR target, so the measure leaves them out too. None: no such voxel."""
    from .volume import declared_fill

    fill = options.get("fill_value")
    if fill is None:
        fill = declared_fill(vol)
    if fill is None:
        return None
    filled = vol.data == fill
    return filled if filled.any() else None


def measure(reference: Volume | np.ndarray, test: Volume | np.ndarray) -> dict[str, Any]:
    """Measure ``test`` against ``reference`` on every voxel (the reference's mask, if any,
    left out): ``max_error``, ``psnr`` (peak: the reference's value range), ``rmse``,
    ``differing`` (voxels whose values or bits differ), ``identical`` and both dtypes. A
    NaN or Inf of the reference is left out of the errors where ``test`` has the same
    special value there (as :func:`compare` does), and is an infinite error elsewhere."""
    from . import metrics
    from .errors import OptionError

    ref = reference if isinstance(reference, Volume) else Volume(np.asarray(reference))
    got = test if isinstance(test, Volume) else Volume(np.asarray(test))
    a, b = ref.data, got.data
    if a.shape != b.shape:
        raise OptionError(
            f"expected two volumes of the same shape, found {'x'.join(map(str, a.shape))} "
            f"and {'x'.join(map(str, b.shape))}"
        )
    left_out = ref.mask
    specials = a.dtype.kind == "f" and not all(np.isfinite(x).all() for (x,) in metrics.chunks(a))
    if specials:  # as compare(): a NaN/Inf
        special = ~np.isfinite(a)  # matched exactly is left out of the error; one not
        matched = special & ((a == b) | (np.isnan(a) & np.isnan(b)))  # matched stays in
        left_out = matched if left_out is None else left_out | matched
    m = metrics.summary(a, b, mask=left_out)
    differing = sum(_differing(x, y) for x, y in metrics.chunks(a, b))
    return {
        "shape": list(a.shape),
        "dtype": a.dtype.name,
        "test_dtype": b.dtype.name,
        "max_error": m["max_error"],
        "psnr": m["psnr"],
        "rmse": m["rmse"],
        "differing": differing,
        "identical": differing == 0 and a.dtype == b.dtype,
    }


def _differing(a: np.ndarray, b: np.ndarray) -> int:
    """Voxels whose values differ; bit for bit between equal dtypes (-0.0 against 0.0
    and NaN payloads count)."""
    if a.dtype == b.dtype:
        same = a.view(f"u{a.itemsize}") == b.view(f"u{b.itemsize}")
    else:
        same = a == b
        if a.dtype.kind == "f" and b.dtype.kind == "f":
            same |= np.isnan(a) & np.isnan(b)
    return int(a.size - np.count_nonzero(same))


def compare_peers(
    vol: Volume | np.ndarray,
    max_error: float | None = None,
    *,
    jpegxl_efforts: tuple[int, ...] | None = None,
    progress=None,
) -> tuple[list[dict[str, Any]], list[str]]:
    """Run the peer codecs of :mod:`volpack.peers` on ``vol``: losslessly, or with every
    voxel within ``max_error``; each encoded and decoded once, in this process. Returns
    a row per peer (``name``, ``note``, ``file_nbytes``, ``ratio``, ``enc_mb_s``,
    ``dec_mb_s``, ``enc_seconds``, ``dec_seconds``, ``max_error``, ``psnr``, ``rmse``,
    ``lossless`` and, under a bound, ``bound_held``), best ratio first, and a line for
    each peer left out (not installed, the array's dtype or shape, NaN/Inf voxels under
    a bound, or the error a peer raised). ``progress(done, total)`` is called as peers
    finish."""
    from . import metrics, peers

    vol = vol if isinstance(vol, Volume) else Volume(np.asarray(vol))
    a = np.ascontiguousarray(vol.data)
    skipped: list[str] = []
    if max_error is None:
        efforts = peers.JPEGXL_EFFORTS if jpegxl_efforts is None else tuple(jpegxl_efforts)
        found, skipped = peers.lossless(a.dtype, a.shape, jpegxl_efforts=efforts)
    elif vol.mask is not None or (a.dtype.kind == "f" and not np.isfinite(a).all()):
        # zfp, SZ3 and SPERR have no notion of a voxel left out: NaN, Inf or a fill value
        # would spread into the bound or the coding; volpack keeps them exact
        found = []
        skipped = [
            "every bounded peer: the volume has NaN, Inf or fill voxels, which zfp, SZ3 and SPERR do not keep"
        ]
    else:
        found, skipped = peers.bounded(a.dtype, a.shape, max_error)
    rows = []
    for done, peer in enumerate(found):
        try:
            t0 = time.perf_counter()
            blob = peer.encode(a)
            enc = time.perf_counter() - t0
            t0 = time.perf_counter()
            back = np.asarray(peer.decode(blob)).reshape(a.shape)
            dec = time.perf_counter() - t0
        except Exception as exc:  # a peer's own failure is reported, not raised
            skipped.append(f"{peer.name}: failed ({type(exc).__name__}: {exc})")
            continue
        size = peers.nbytes(blob)
        m = measure(vol, back)  # NaN/Inf matched exactly are left out, as for volpack
        row = {
            "name": peer.name,
            "note": peer.note,
            "file_nbytes": size,
            "ratio": metrics.ratio(a.nbytes, size),
            "bpv": metrics.bits_per_voxel(size, a.size),
            "max_error": m["max_error"],
            "psnr": m["psnr"],
            "rmse": m["rmse"],
            "lossless": m["identical"],
            "enc_seconds": enc,
            "dec_seconds": dec,
            "enc_mb_s": metrics.throughput(a.nbytes, enc),
            "dec_mb_s": metrics.throughput(a.nbytes, dec),
        }
        if max_error is not None:
            row["bound_held"] = bool(m["max_error"] <= max_error)
        rows.append(row)
        if progress is not None:
            progress(done + 1, len(found))
    rows.sort(key=lambda r: -r["ratio"])
    return rows, skipped
