"""Special voxels of animation frames: NaN, +-Inf and the fill value, kept exactly.

An encoder finds them (:func:`volpack.volume_codec.specials.special_mask`), puts the last
valid value before them in their place (:func:`~volpack.volume_codec.specials.fill_masked`)
so that motion search, prediction and the field codecs see an ordinary field, and
stores them in a section of the frame: the distinct bit patterns they hold (a palette)
and a label per voxel (0: valid, k: palette entry k). A P- or B-frame may code the labels
against its previous anchor's special voxels instead (0: as there, 1: valid, k + 1:
palette entry k), which costs next to nothing where the mask holds still (land and
sea). Anchors predict from their decoded frame with the specials filled the same way
(:func:`reference`), so encoder and decoder predict alike. ``formats/animation-1.md``,
"Special voxels", gives the bytes.
"""

from __future__ import annotations

import struct

import numpy as np

from ..errors import FormatError
from ..volume_codec.protocol import as_stored, from_stored
from ..volume_codec.specials import fill_masked, special_mask, special_voxels
from . import motion
from .linecode import decode_line, encode_line

ALONE, AGAINST_PREVIOUS = 0, 1
_HEAD = struct.Struct("<BI")  # how the labels are coded, palette size


def reference(frame: np.ndarray, fill: float | None) -> motion.Reference:
    """The anchor an exactly decoded ``frame`` makes: predictions read it with its
    special voxels filled; ``exact`` keeps them (the labels of later frames refer to it)."""
    mask = special_mask(frame, fill)
    if mask is None:
        return motion.Reference(frame)
    return motion.Reference(fill_masked(frame, mask), exact=frame)


def _bits(x: np.ndarray) -> np.ndarray:
    return x.view(f"u{x.dtype.itemsize}")


def encode(x: np.ndarray, mask: np.ndarray, prev: motion.Reference | None, fill) -> bytes:
    """The section of frame ``x`` whose special voxels are ``mask`` (not empty): labels
    coded alone or, given the previous anchor, against it, whichever is shorter."""
    bits = _bits(x)
    palette = np.unique(bits[mask])
    labels = np.zeros(x.shape, np.int64)
    labels[mask] = np.searchsorted(palette, bits[mask]) + 1
    head = as_stored(palette.view(x.dtype))
    best = _HEAD.pack(ALONE, palette.size) + head + encode_line(labels)
    if prev is not None:
        r = prev.exact
        rmask = special_voxels(r, fill)
        same = (mask == rmask) & (~mask | (bits == _bits(r)))
        sym = np.where(same, 0, np.where(mask, labels + 1, 1))
        diff = _HEAD.pack(AGAINST_PREVIOUS, palette.size) + head + encode_line(sym)
        if len(diff) < len(best):
            best = diff
    return best


def restore(body, out: np.ndarray, prev: motion.Reference | None, fill) -> None:
    """Put the special voxels of section ``body`` into the decoded frame ``out``."""
    data = memoryview(body)
    if len(data) < _HEAD.size:
        raise FormatError("animation frame: the special voxels section is too short")
    how, k = _HEAD.unpack(data[: _HEAD.size])
    item = out.dtype.itemsize
    if how not in (ALONE, AGAINST_PREVIOUS) or not 1 <= k <= out.size:
        raise FormatError(
            f"animation frame: special voxels coded as {how} with {k} values, expected "
            f"0 or 1 with 1..{out.size}"
        )
    if len(data) < _HEAD.size + k * item:
        raise FormatError("animation frame: the special voxels' palette runs past the section")
    palette = from_stored(data[_HEAD.size : _HEAD.size + k * item], (k,), out.dtype)
    if not special_voxels(palette, fill).all():
        raise FormatError(
            "animation frame: a special voxel's value is neither NaN, Inf nor the fill"
        )
    sym = decode_line(data[_HEAD.size + k * item :], out.shape)
    top = k + (how == AGAINST_PREVIOUS)
    if sym.min(initial=0) < 0 or sym.max(initial=0) > top:
        raise FormatError(f"animation frame: a special voxel label outside 0..{top}")
    flat, s = out.reshape(-1), sym.reshape(-1)
    if how == AGAINST_PREVIOUS:
        if prev is None:
            raise FormatError("animation frame: special voxels coded against a missing anchor")
        r = prev.exact.reshape(-1)
        keep = (s == 0) & special_voxels(r, fill)
        flat[keep] = r[keep]
        s = np.where(s > 1, s - 1, 0)
    hit = s > 0
    flat[hit] = palette[s[hit] - 1]
