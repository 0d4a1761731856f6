"""The bundled demo: every codec volpack has, run on a real MRI and checked.

``volpack demo`` calls :func:`run`, which writes into a folder (``./volpack-demo/`` by
default) and returns one row per stage; the CLI prints them as a table.
"""

from __future__ import annotations

import gzip
import io
import os
import re
import time
from collections.abc import Callable
from importlib import resources
from typing import Any

import numpy as np

from .volume import Volume

DEMO_NAME = "brainsmall"


def load_demo_volume() -> Volume:
    """The bundled head MRI (84 x 128 x 128 uint8); see ``volpack/data/README.md``."""
    raw = resources.files("volpack").joinpath("data", "brainsmall.npy.gz").read_bytes()
    data = np.load(io.BytesIO(gzip.decompress(raw)), allow_pickle=False)
    return Volume(data, meta={"source": "VolPack brainsmall head MRI (public domain)"})


def _timed(fn: Callable[[], Any], repeat: int) -> tuple[Any, float]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def stages() -> list[tuple[str, dict[str, Any]]]:
    """(label, compress options) of every codec stage the demo runs."""
    out = []
    for coder in ("arith", "huffman", "rle"):
        out.append(
            (f"wavelet 5/3 + {coder}", {"codec": "wavelet", "wavelet": "53", "coder": coder})
        )
    out.append(("wavelet 2/6 + arith", {"codec": "wavelet", "wavelet": "26", "coder": "arith"}))
    out.append(
        (
            "wavelet 5/3 + huffman, line order",
            {"codec": "wavelet", "wavelet": "53", "coder": "huffman", "order": "line"},
        )
    )
    out.append(("zstd (byte-shuffled)", {"codec": "zstd"}))
    out.append(("lossy: max error 2", {"max_error": 2}))
    out.append(("lossy: quality 63", {"quality": 63}))
    out.append(("lossy: PSNR 45 dB target", {"psnr": 45.0}))
    out.append(("lossy: quality 63, CDF 9/7 (float)", {"quality": 63, "wavelet": "cdf97"}))
    return out


def _is_lossless(opts: dict[str, Any]) -> bool:
    lossy = ("max_error", "rel_error", "psnr", "ratio", "quality", "threshold")
    return not any(k in opts for k in lossy)


def run(
    folder: str = "volpack-demo",
    *,
    repeat: int = 3,
    progress: Callable[[int, int], None] | None = None,
    force: bool = True,
) -> dict[str, Any]:
    """Run the demo; return ``{'folder', 'input', 'rows'}`` (one row per stage).

    Each row: ``stage``, ``file``, ``nbytes``, ``ratio``, ``psnr`` (None when lossless),
    ``max_error``, ``lossless``, ``enc_mb_s``, ``dec_mb_s``. A failed round trip raises.
    """
    from . import api, metrics
    from . import io as vio
    from .errors import VolpackError

    os.makedirs(folder, exist_ok=True)
    vol = load_demo_volume()
    src = os.path.join(folder, f"{DEMO_NAME}.npy")
    vio.write_volume(vol, src, force=True)
    todo = stages()
    rows = []
    for i, (label, opts) in enumerate(todo):
        slug = re.sub(r"[^a-z0-9]+", "-", label.lower().replace("/", "")).strip("-")
        path = os.path.join(folder, f"{DEMO_NAME}-{slug}.vpk")
        api.compress(vol, path, force=force, **opts)  # warms the kernels, writes the file
        blob, enc = _timed(lambda o=opts: api.compress_array(vol, **o), repeat)
        with open(path, "rb") as f:
            if f.read() != api.compress_array(vol, **{**opts, "workers": 2}):
                raise VolpackError(
                    f"demo: {label} is not deterministic (1 and 2 workers give other bytes)"
                )
        dec_vol, dec = _timed(lambda p=path: api.decompress(p), repeat)
        back = dec_vol.data
        lossless = bool(np.array_equal(back, vol.data))
        bound = opts.get("max_error")
        if lossless != _is_lossless(opts):
            raise VolpackError(f"demo: {label} did not round-trip as expected")
        if bound is not None and metrics.max_error(vol.data, back) > bound:
            raise VolpackError(f"demo: {label} broke its error bound {bound}")
        rows.append(
            {
                "stage": label,
                "file": path,
                "nbytes": len(blob),
                "ratio": vol.nbytes / len(blob),
                "psnr": None if lossless else metrics.psnr(vol.data, back),
                "max_error": metrics.max_error(vol.data, back),
                "lossless": lossless,
                "enc_mb_s": metrics.throughput(vol.nbytes, enc),
                "dec_mb_s": metrics.throughput(vol.nbytes, dec),
            }
        )
        if progress is not None:
            progress(i + 1, len(todo))
    return {
        "folder": folder,
        "input": src,
        "shape": list(vol.shape),
        "dtype": str(vol.dtype),
        "rows": rows,
        "preview": _preview(rows[0]["file"], os.path.join(folder, f"{DEMO_NAME}.png")),
    }


def _preview(vpk: str, png: str) -> dict[str, Any]:
    """Decode the first stage's file and ray-cast it to a PNG (pre-integrated, Phong)."""
    from . import api
    from .render import transfer
    from .render.camera import Camera
    from .render.image import save_png
    from .render.raycast import render

    vol = api.decompress(vpk)
    lo, hi = float(vol.data.min()), float(vol.data.max())
    tf = transfer.auto_tf(lo, hi, vol.dtype)
    image, stats = render(
        vol,
        tf=tf,
        camera=Camera(azimuth=120, elevation=15, zoom=1.5, size=(256, 256)),
        shading="phong",
        render_stats=True,
    )
    save_png(png, image, colorbar=(tf, lo, hi), force=True)
    return {"file": png, "seconds": stats.seconds, "samples_per_s": stats.samples_per_s}
