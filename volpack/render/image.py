"""Rendered images out: 8-bit RGB conversion and atomic PNG files (Pillow).

The ray caster returns pre-multiplied RGBA on black; :func:`to_rgb8` composites it over
a background colour. :func:`save_png` can draw the transfer function under the image:
a strip whose colour is the TF colour across the value range, filled from the bottom up
to the TF opacity (scaled to the largest opacity so faint TFs stay visible), with the
range ends written beneath it.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from ..errors import VolpackError
from ..format.atomic import atomic_open


def to_rgb8(rgba: np.ndarray, background: Sequence[float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Composite pre-multiplied ``(h, w, 4)`` RGBA over ``background`` (RGB in [0, 1]);
    return ``(h, w, 3)`` uint8."""
    a = np.asarray(rgba, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 4:
        raise VolpackError(f"expected an (h, w, 4) RGBA image, found shape {a.shape}")
    bg = np.asarray(background, dtype=np.float32)
    if bg.shape != (3,) or not np.all((bg >= 0) & (bg <= 1)):
        raise VolpackError(f"expected a background (r, g, b) in [0, 1], found {background}")
    # one float32 copy worked in place (a 512x512 frame: 10 -> 4 ms, on every frame of
    # a walk's critical path); NaN counts as 0, infinities clip, as nan_to_num had them
    rgb = np.nan_to_num(a[..., :3])  # a copy: the caller's image is left alone
    if bg.any():  # over black the composite adds zeros (only a -0.0 would turn +0.0)
        rgb += (1.0 - np.clip(np.nan_to_num(a[..., 3:4]), 0.0, 1.0)) * bg
    np.clip(rgb, 0.0, 1.0, out=rgb)
    rgb *= 255.0
    return np.rint(rgb, out=rgb).astype(np.uint8)


def colorbar(table: np.ndarray, width: int, height: int) -> np.ndarray:
    """An ``(height, width, 3)`` uint8 strip drawing the ``(n, 4)`` TF table."""
    tab = np.asarray(table, dtype=np.float64)
    if tab.ndim != 2 or tab.shape[1] != 4 or tab.shape[0] < 1:
        raise VolpackError(f"expected an (n, 4) transfer-function table, found {tab.shape}")
    xs = np.linspace(0, tab.shape[0] - 1, width)
    cols = np.stack([np.interp(xs, np.arange(tab.shape[0]), tab[:, k]) for k in range(4)], 1)
    peak = cols[:, 3].max()
    level = cols[:, 3] / peak if peak > 0 else np.zeros(width)
    rows = (height - 1 - np.arange(height))[:, None] / max(height - 1, 1)  # 1 at the top
    filled = rows <= level[None, :] + 1e-9
    strip = np.where(filled[..., None], cols[None, :, :3], 0.15 * cols[None, :, :3] + 0.1)
    return np.rint(np.clip(strip, 0, 1) * 255).astype(np.uint8)


def compose(
    rgba: np.ndarray,
    *,
    colorbar_tf=None,
    background: Sequence[float] = (0.0, 0.0, 0.0),
):
    """The Pillow image :func:`save_png` writes (image, and the colour bar if asked)."""
    from PIL import Image

    rgb = to_rgb8(rgba, background)
    img = Image.fromarray(rgb, "RGB")
    if colorbar_tf is None:
        return img
    from PIL import ImageDraw
    try:
        tf, lo, hi = colorbar_tf
    except (TypeError, ValueError):
        raise VolpackError(
            f"expected colorbar=(tf, lo, hi), found {type(colorbar_tf).__name__}"
        ) from None
    lo, hi = float(lo), float(hi)
    table = tf.table(lo, hi, 256) if hasattr(tf, "table") else np.asarray(tf)
    w, h = img.size
    bar_h = max(8, h // 12)
    text_h = 12
    canvas = Image.new("RGB", (w, h + bar_h + text_h + 4), (0, 0, 0))
    canvas.paste(img, (0, 0))
    canvas.paste(Image.fromarray(colorbar(table, w, bar_h), "RGB"), (0, h + 2))
    draw = ImageDraw.Draw(canvas)
    y = h + bar_h + 3
    left, right = f"{lo:.6g}", f"{hi:.6g}"
    draw.text((1, y), left, fill=(220, 220, 220))
    rw = draw.textlength(right)
    if rw + draw.textlength(left) + 4 < w:
        draw.text((w - rw - 1, y), right, fill=(220, 220, 220))
    return canvas


def save_png(
    path: str | os.PathLike,
    rgba: np.ndarray,
    colorbar=None,
    *,
    background: Sequence[float] = (0.0, 0.0, 0.0),
    force: bool = False,
) -> None:
    """Write ``rgba`` (pre-multiplied, ``(h, w, 4)``) as an RGB PNG, atomically.

    ``colorbar`` is ``None`` or ``(tf, lo, hi)`` (a TransferFunction or an ``(n, 4)``
    table over ``[lo, hi]``): the TF is drawn under the image. An existing ``path`` is
    replaced only with ``force``; ``'-'`` writes to standard output.
    """
    _save(path, compose(rgba, colorbar_tf=colorbar, background=background), force)


def save_rgb8(path: str | os.PathLike, rgb: np.ndarray, *, force: bool = False) -> None:
    """Write ``rgb`` (:func:`to_rgb8`'s ``(h, w, 3)`` uint8) as a PNG, atomically: the bytes
    :func:`save_png` writes for the RGBA it came from, for a caller that has converted it
    already (a movie's frames: the conversion is 5-10 ms of a 512x512 frame)."""
    from PIL import Image

    _save(path, Image.fromarray(rgb, "RGB"), force)


def ready_png() -> None:
    """Import Pillow and let it register its formats now (about 20 ms, which its first
    ``save`` would otherwise spend), for a caller with time to spare before it writes."""
    from PIL import Image

    Image.preinit()


def _save(path, img, force: bool) -> None:
    with atomic_open(path, force=force) as f:
        img.save(f, format="PNG")
