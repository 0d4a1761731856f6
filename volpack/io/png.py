"""PNG (read-only, through Pillow): one greyscale image is a volume of one slice; a folder
of them, named in natural order, is a stack.

Slice exports of micro-CT and microscopy instruments and of image datasets often come as
8- or 16-bit greyscale PNGs. Colour, palette and alpha images are refused (a volume holds
one value a voxel); bilevel images read as uint8 0/1. PNG records no slice thickness and
volpack takes no pixel size from its optional ``pHYs`` chunk (a print resolution more
often than a physical one): spacing is 1.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from ..errors import FormatError
from .common import ReadOptions, check_voxels, folder_slices, header_dict, to_volume

_PNG_EXTS = (".png",)
# Pillow's modes for greyscale PNGs and the dtype each reads as (Pillow before 10 opens a
# 16-bit PNG as "I": PNG has no wider greyscale, so its values fit uint16)
_MODES = {"1": np.uint8, "L": np.uint8, "I;16": np.uint16, "I;16B": np.uint16, "I": np.uint16}


def _open(path: str):
    from PIL import Image, UnidentifiedImageError

    try:
        img = Image.open(path)
    except (UnidentifiedImageError, OSError, ValueError) as e:
        raise FormatError(f"expected a PNG image in {path!r}, found an error: {e}") from e
    if img.format != "PNG":
        img.close()
        raise FormatError(f"expected a PNG image in {path!r}, found {img.format} data")
    if img.mode not in _MODES:
        img.close()
        raise FormatError(
            f"expected a greyscale PNG (8 or 16 bits, no alpha) in {path!r}, found mode "
            f"{img.mode!r}; convert it to one channel first"
        )
    return img


def _pixels(img, path: str) -> np.ndarray:
    try:
        a = np.asarray(img)
    except (OSError, ValueError, SyntaxError) as e:  # truncated or damaged image data
        raise FormatError(f"expected PNG image data in {path!r}, found an error: {e}") from e
    return a.astype(_MODES[img.mode], copy=False)


def read(path: str, opts: ReadOptions) -> Any:
    with _open(path) as img:
        check_voxels((1, img.height, img.width), opts.max_voxels, path)
        a = _pixels(img, path)
    return to_volume(a, {"source_format": "png"}, path, shape=(1, *a.shape))


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    with _open(path) as img:
        shape, dtype = (1, img.height, img.width), _MODES[img.mode]
    return header_dict(
        "png", shape, dtype, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), {"source_format": "png"}
    )


def read_folder(path: str, opts: ReadOptions) -> Any:
    names = folder_slices(path, _PNG_EXTS)
    if not names:
        raise FormatError(f"expected .png slices in {path!r}, found none")
    with _open(os.path.join(path, names[0])) as img:
        yx, dtype = (img.height, img.width), _MODES[img.mode]
    check_voxels((len(names), *yx), opts.max_voxels, path)
    out = np.empty((len(names), *yx), dtype=dtype)
    for i, name in enumerate(names):
        with _open(os.path.join(path, name)) as img:
            sl = _pixels(img, os.path.join(path, name))
        if sl.shape != yx or sl.dtype != dtype:
            raise FormatError(
                f"expected every slice in {path!r} to be {yx} {np.dtype(dtype)} like "
                f"{names[0]!r}, found {name!r} {sl.shape} {sl.dtype}"
            )
        out[i] = sl
    return to_volume(out, {"source_format": "png-folder", "slices": len(names)}, path)
