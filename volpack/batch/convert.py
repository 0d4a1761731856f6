"""One batch task: convert (compress or decompress) one file, verify it, and return a
plain record; :func:`convert_one` never raises for a problem of its file."""

import contextlib
import math
import os
import time
from typing import Any

from ..errors import OptionError, VolpackError
from ..metrics import psnr_from_sse
from .journal import input_stat, output_stat
from .planning import COMPRESS_KEYS, READ_KEYS, Task


class VerifyError(VolpackError):
    """An output does not decode to its input (within the bound)."""


# -- one task --------------------------------------------------------------------------


def convert_one(task: Task) -> dict[str, Any]:
    """Run one task and return its record; never raises for a problem of its file.

    ``status`` is ``ok`` (written and verified) or ``failed`` (``error`` says why; a
    written output that fails verification is removed). Also ``raw_nbytes`` (voxel
    bytes), ``nbytes`` (the ``.vpk`` file's size), ``ratio``, ``max_error`` and ``psnr``
    (measured; ``None`` when lossless), ``seconds``, and the input's size and mtime and
    the output's size and sha256 for the journal.
    """
    t0 = time.perf_counter()
    rec: dict[str, Any] = {
        "input": task.input,
        "output": task.output,
        "status": "failed",
        "error": None,
        "raw_nbytes": None,
        "nbytes": None,
        "ratio": None,
        "max_error": None,
        "psnr": None,
        "options_hash": task.options_hash,
    }
    try:
        rec.update(input_stat(task.input))
        if task.kind == "compress":
            rec.update(_compress_one(task))
        elif task.kind == "decompress":
            rec.update(_decompress_one(task))
        else:
            raise OptionError(f"expected kind 'compress' or 'decompress', found {task.kind!r}")
        rec.update(output_stat(task.output))
        rec["status"] = "ok"
    except Exception as e:  # one file's problem is its record, not the run's
        rec["error"] = one_line(e)
    rec["seconds"] = time.perf_counter() - t0
    return rec


def _compress_one(task: Task) -> dict[str, Any]:
    from .. import api

    read_kw = {k: task.options[k] for k in READ_KEYS if k in task.options}
    comp_kw = {k: task.options[k] for k in COMPRESS_KEYS if k in task.options}
    vol = api.read_volume(task.input, **read_kw)
    os.makedirs(os.path.dirname(os.path.abspath(task.output)), exist_ok=True)
    stats = api.compress(vol, task.output, force=task.force, **comp_kw)
    try:
        if task.verify == "decode":
            back = api.decompress(task.output, workers=comp_kw.get("workers", 1))
            err, psnr = compare(vol.data, back.data, stats)
        else:
            _check_chunks(task.output)
            err = None if stats["lossless"] else stats["max_error"]
            psnr = stats.get("psnr")
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(task.output)
        raise
    size = os.path.getsize(task.output)
    return {
        "raw_nbytes": stats["raw_nbytes"],
        "nbytes": size,
        "ratio": stats["raw_nbytes"] / max(size, 1),
        "lossless": stats["lossless"],
        "max_error": err,
        "psnr": psnr,
    }


def _decompress_one(task: Task) -> dict[str, Any]:
    import numpy as np

    from .. import api
    from .. import io as vio

    vol = api.decompress(task.input, workers=task.options.get("workers", 1))  # CRCs checked
    os.makedirs(os.path.dirname(os.path.abspath(task.output)), exist_ok=True)
    vio.write_volume(vol, task.output, force=task.force)
    if task.verify == "decode":
        back = vio.read_volume(task.output)
        if back.shape != vol.shape or not np.array_equal(
            back.data, vol.data, equal_nan=vol.dtype.kind == "f"
        ):
            with contextlib.suppress(OSError):
                os.unlink(task.output)
            raise VerifyError(f"{task.output}: reading it back does not give the decoded volume")
    size = os.path.getsize(task.input)
    return {"raw_nbytes": vol.nbytes, "nbytes": size, "ratio": vol.nbytes / max(size, 1)}


def _check_chunks(path: str) -> None:
    from ..format.container import Reader

    with Reader(path, verify=True) as r:
        for _ in r:  # every payload read, every CRC checked
            pass


def compare(a, b, stats: dict, block: int = 1 << 22) -> tuple[float | None, float | None]:
    """Check the decoded ``b`` against the input ``a``: equal when lossless, within the
    stored bound when there is one; special values (NaN, Inf) must come back exactly.
    Return the measured ``(max_error, psnr)`` (``None, None`` when lossless). Works in
    blocks so the float64 differences never cost more than a few tens of MB."""
    import numpy as np

    if a.shape != b.shape:
        raise VerifyError(f"expected the decoded shape {a.shape}, found {b.shape}")
    fa, fb = a.reshape(-1), b.reshape(-1)
    if stats.get("lossless", False):
        for i in range(0, fa.size, block):
            x, y = fa[i : i + block], fb[i : i + block]
            if not np.array_equal(x, y, equal_nan=x.dtype.kind == "f"):
                raise VerifyError("expected a lossless round trip, found different voxels")
        return None, None
    worst, sse, n, lo, hi = 0.0, 0.0, 0, np.inf, -np.inf
    for i in range(0, fa.size, block):
        x = fa[i : i + block].astype(np.float64)
        y = fb[i : i + block].astype(np.float64)
        fin = np.isfinite(x)
        special = ~fin
        if special.any() and not np.array_equal(x[special], y[special], equal_nan=True):
            raise VerifyError("expected NaN/Inf voxels restored exactly, found them changed")
        d = np.abs(x[fin] - y[fin])
        if d.size:
            worst = max(worst, float(d.max()))
            sse += float(np.dot(d, d))
            n += d.size
            lo, hi = min(lo, float(x[fin].min())), max(hi, float(x[fin].max()))
    bound = stats.get("error_bound")
    if bound is not None and worst > bound * (1 + 1e-12):
        raise VerifyError(f"expected every voxel within {bound:g}, found an error of {worst:g}")
    psnr = psnr_from_sse(sse, n, (hi - lo) if n and hi > lo else 1.0)
    return worst, None if psnr == math.inf else psnr


def one_line(e: BaseException) -> str:
    msg = str(e) or type(e).__name__
    if isinstance(e, OSError) and e.filename and e.strerror:
        msg = f"{e.filename}: {e.strerror}"
    if not isinstance(e, VolpackError):
        msg = f"{type(e).__name__}: {msg}"
    return " ".join(msg.split())
