"""Preprocessing: crop, pad, downsample, resample, window, convert and quantise volumes.

Every public function takes a :class:`~volpack.volume.Volume` and returns a new one with
its geometry kept right: ``origin`` is the position of voxel ``(0, 0, 0)`` and moves when
voxels are cut off, added or merged; ``spacing`` follows any change of resolution. Only the
three spatial axes ``(z, y, x)`` are touched; a leading time axis is never filtered.

Floats never become integers silently. :func:`quantize` maps them to unsigned codes with a
recorded scale, offset and measured error; :func:`astype` rounds by an explicit rule and
counts what it clips; NaN, Inf and fill values are moved into ``Volume.mask`` by
:func:`mask_special` and put back bit-for-bit by :func:`unmask_special`.

Everything here is plain numpy: the filters are separable, a few taps per output voxel.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from .errors import FormatError, OptionError
from .volume import Volume

# codes of special values in meta['special']['kinds'] (one per masked voxel, C order)
KIND_NAN, KIND_POSINF, KIND_NEGINF, KIND_FILL = 1, 2, 3, 4
_KIND_KEYS = {KIND_NAN: "nan", KIND_POSINF: "posinf", KIND_NEGINF: "neginf", KIND_FILL: "nfill"}
_AXIS_NAMES = ("t", "z", "y", "x")
_ROUNDING = {"nearest": np.rint, "floor": np.floor, "trunc": np.trunc}
_CHUNK = 1 << 22  # voxels per quantisation pass


def parse_ranges(text: str, shape, *, what: str = "range") -> tuple[slice, ...]:
    """Parse ``"z0:z1,y0:y1,x0:x1"`` into slices checked against ``shape``.

    Each part is ``start:stop`` (either may be empty, negatives count from the end, as in
    numpy), a single index ``i`` (meaning ``i:i+1``) or empty (the whole axis). Unlike numpy
    slicing, a range reaching past the axis or selecting nothing is an error. For a 4-D
    shape, three parts leave the time axis whole; four parts give ``t,z,y,x``.

    Raises
    ------
    FormatError
        On malformed text or an out-of-range part, e.g.
        ``crop 10:900 on axis z of length 108: expected 0 <= start < stop <= 108``.
    """
    if not isinstance(text, str):
        raise TypeError(f"expected ranges as text like '10:90,:,:', found {text!r}")
    shape = tuple(int(n) for n in shape)
    parts = [p.strip() for p in text.split(",")]
    if len(shape) == 4 and len(parts) == 3:
        parts.insert(0, "")
    if len(parts) != len(shape):
        names = ",".join(_AXIS_NAMES[-len(shape) :])
        raise FormatError(
            f"expected {len(shape)} comma-separated ranges ({names}), found {what} {text!r}"
        )
    out = []
    for part, n, axis in zip(parts, shape, _AXIS_NAMES[-len(shape) :], strict=True):
        fields = part.split(":") if part else ["", ""]
        try:
            if len(fields) == 1:
                start = int(fields[0])
                stop = start + 1 if start != -1 else None
            elif len(fields) == 2:
                start, stop = (int(f) if f.strip() else None for f in fields)
            else:
                raise ValueError
        except ValueError:
            raise FormatError(
                f"expected {what} START:STOP with integers on axis {axis}, found {part!r}"
            ) from None
        out.append(_bounded_slice(start, stop, n, f"{what} {part} on axis {axis}"))
    return tuple(out)


def crop(vol: Volume, ranges) -> Volume:
    """Keep a box of voxels; ``ranges`` is text for :func:`parse_ranges` or a tuple of
    slices (step 1). The origin moves by ``start * spacing`` on each axis."""
    sl = _as_slices(ranges, vol.shape, "crop")
    origin = tuple(
        o + s.start * d for o, s, d in zip(vol.origin, sl[-3:], vol.spacing, strict=True)
    )
    mask, meta = None, _meta(vol)
    if vol.mask is not None:
        mask = vol.mask[sl].copy()
        if "special" in meta:
            codes = np.zeros(vol.shape, np.uint8)
            codes[vol.mask] = _special_kinds(meta["special"], int(vol.mask.sum()))
            meta["special"] = _special_record(codes[sl][mask], meta["special"].get("fill"))
    return vol.replace(data=vol.data[sl].copy(), origin=origin, mask=mask, meta=meta)


def pad(vol: Volume, widths, mode: str = "edge", value=0) -> Volume:
    """Add voxels around the volume.

    Parameters
    ----------
    widths : int, three ints, or three ``(before, after)`` pairs
        Voxels to add on the spatial axes ``(z, y, x)``.
    mode : {"edge", "constant"}
        Repeat the border voxel, or fill with ``value``.

    The origin moves back by ``before * spacing``; padded voxels are never masked.
    """
    if mode not in ("edge", "constant"):
        raise OptionError(f"expected mode 'edge' or 'constant', found {mode!r}")
    w = np.asarray(widths, dtype=np.int64)
    if w.ndim == 0 or w.shape == (3,):
        w = np.broadcast_to(w[..., None], (3, 2))
    if w.shape != (3, 2) or (w < 0).any():
        raise OptionError(f"expected non-negative pad widths for (z, y, x), found {widths!r}")
    full = [(0, 0)] * (vol.data.ndim - 3) + [tuple(int(v) for v in p) for p in w]
    if mode == "constant":
        fill = np.asarray(value).astype(vol.dtype)
        if fill != value:
            raise OptionError(f"expected a pad value that {vol.dtype} holds, found {value!r}")
        data = np.pad(vol.data, full, mode="constant", constant_values=fill)
    else:
        data = np.pad(vol.data, full, mode="edge")
    mask = None if vol.mask is None else np.pad(vol.mask, full, constant_values=False)
    origin = tuple(o - int(p[0]) * d for o, p, d in zip(vol.origin, w, vol.spacing, strict=True))
    return vol.replace(data=data, origin=origin, mask=mask, meta=_meta(vol))


def pad_to_multiple(vol: Volume, multiple) -> Volume:
    """Pad each spatial axis at its end (edge values) up to a multiple of ``multiple``
    (one int or one per axis), e.g. of ``2**levels`` before a wavelet transform."""
    m = np.broadcast_to(np.asarray(multiple, dtype=np.int64), (3,))
    if (m < 1).any():
        raise OptionError(f"expected a positive multiple, found {multiple!r}")
    return pad(vol, [(0, int(-n % k)) for n, k in zip(vol.shape[-3:], m, strict=True)])


def downsample(vol: Volume, factor=2, method: str = "box") -> Volume:
    """Shrink each spatial axis by an integer factor.

    Output voxel ``i`` stands for input voxels ``i*f .. i*f+f-1`` and sits at their centre,
    so ``origin += (f-1)/2 * spacing`` and ``spacing *= f``; an axis of ``n`` voxels becomes
    ``ceil(n / f)``.

    ``box`` averages each block; a partial last block is averaged over the voxels it has.
    ``gaussian`` weighs input ``j`` by ``exp(-(j-c)**2 / (2 sigma**2))`` around the block
    centre ``c`` with ``sigma = f/3``, cut at ``|j-c| <= f`` (three sigma) and normalised
    over the taps inside the volume. Sums run in float64; integer results are rounded half
    to even and cast back to the input dtype (the average of integers fits), floats keep
    their dtype. Box averages of integers are exact (one division of an exact sum) as long
    as ``|sum| < 2**53``. NaN spreads to its block. A masked volume is refused.
    """
    f = _spatial_ints(factor, "factor")
    if method not in ("box", "gaussian"):
        raise OptionError(f"expected method 'box' or 'gaussian', found {method!r}")
    _require_unmasked(vol, "downsample")
    acc = vol.data.astype(np.float64)
    nd = acc.ndim
    counts = np.ones((1,) * 3)
    for k in range(3):
        n = vol.shape[nd - 3 + k]
        if f[k] == 1:
            continue
        idx, w = _downsample_taps(n, f[k], method)
        acc = _apply_taps(acc, idx, w, nd - 3 + k)
        shape = [1, 1, 1]
        shape[k] = -1
        counts = counts * w.sum(axis=1).reshape(shape)
    if method == "box":
        acc /= counts
    spacing = tuple(d * k for d, k in zip(vol.spacing, f, strict=True))
    origin = tuple(o + (k - 1) / 2 * d for o, k, d in zip(vol.origin, f, vol.spacing, strict=True))
    return vol.replace(data=_back_to(acc, vol.dtype), spacing=spacing, origin=origin, mask=None)


def resample(vol: Volume, spacing, order: int = 1) -> Volume:
    """Resample to a new voxel spacing (one number for isotropic, or one per axis).

    Voxel 0 keeps its position (``origin`` is unchanged) and the new grid stays inside the
    old extent: an axis spanning ``(n-1)*old`` gets ``floor((n-1)*old/new) + 1`` samples.
    ``order=1`` interpolates linearly along each axis in turn (trilinear); ``order=0`` takes
    the nearest voxel (ties go up). Integers are rounded half to even back to their dtype;
    floats keep theirs. A masked volume is refused.
    """
    new = np.broadcast_to(np.asarray(spacing, dtype=np.float64), (3,))
    if not (np.isfinite(new).all() and (new > 0).all()):
        raise OptionError(f"expected positive finite spacing, found {spacing!r}")
    if order not in (0, 1):
        raise OptionError(f"expected order 0 (nearest) or 1 (linear), found {order!r}")
    _require_unmasked(vol, "resample")
    acc = vol.data.astype(np.float64)
    nd = acc.ndim
    # the axes that shrink most go first, so later passes run over fewer voxels
    for k in sorted(range(3), key=lambda k: vol.spacing[k] / new[k]):
        n, old = vol.shape[nd - 3 + k], vol.spacing[k]
        if new[k] != old:
            acc = _apply_taps(acc, *_resample_taps(n, old, float(new[k]), order), nd - 3 + k)
    return vol.replace(
        data=_back_to(acc, vol.dtype), spacing=tuple(float(s) for s in new), mask=None
    )


def window(vol: Volume, lo, hi) -> Volume:
    """Clamp values to ``[lo, hi]``; for integers the bounds are ``ceil(lo)``, ``floor(hi)``
    limited to the dtype's range. NaN stays NaN."""
    if not lo <= hi:
        raise OptionError(f"expected lo <= hi, found {lo!r} > {hi!r}")
    if vol.dtype.kind in "iu":
        info = np.iinfo(vol.dtype)
        lo = min(max(math.ceil(lo), int(info.min)), int(info.max))
        hi = min(max(math.floor(hi), int(info.min)), int(info.max))
        if lo > hi:
            raise OptionError(f"expected a window holding an integer, found {lo}..{hi}")
    elif vol.dtype.kind == "f":
        top = float(np.finfo(vol.dtype).max)  # a bound past the type's range changes nothing
        lo, hi = min(max(float(lo), -top), top), min(max(float(hi), -top), top)
    data = np.clip(vol.data, lo, hi).astype(vol.dtype, copy=False)
    return vol.replace(data=data, meta=_meta(vol))


def astype(vol: Volume, dtype, rounding: str = "nearest", clip: bool = True) -> Volume:
    """Convert the voxel type with explicit rounding and range handling.

    Parameters
    ----------
    dtype : dtype-like
        Any integer or float type.
    rounding : {"nearest", "floor", "trunc"}
        Float to integer only: ``nearest`` rounds half to even.
    clip : bool
        Values outside the target range (finite ones, for a float target) are clamped to
        it and counted in ``meta['clipped']``; with ``clip=False`` they raise OptionError.

    Raises
    ------
    FormatError
        NaN or Inf outside the mask when converting to integers (mask them first).
    """
    dt = np.dtype(dtype)
    if dt.kind not in "iuf":
        raise OptionError(f"expected an integer or float dtype, found {dt}")
    if rounding not in _ROUNDING:
        raise OptionError(f"expected rounding in {sorted(_ROUNDING)}, found {rounding!r}")
    x = vol.data.astype(np.uint8) if vol.dtype.kind == "b" else vol.data
    valid = None if vol.mask is None else ~vol.mask
    bounds = None
    if x.dtype.kind == "f" and dt.kind in "iu":
        bad = ~np.isfinite(x) if valid is None else ~np.isfinite(x) & valid
        if bad.any():
            raise FormatError(
                f"expected finite values to convert to {dt}, found {int(bad.sum())} NaN/Inf; "
                "call mask_special first"
            )
        x = _ROUNDING[rounding](x)
        bounds = _int_bounds_as_float(dt, x.dtype)
    elif dt.kind in "iu":
        src, dst = np.iinfo(x.dtype), np.iinfo(dt)
        if src.min < dst.min or src.max > dst.max:
            bounds = (max(src.min, dst.min), min(src.max, dst.max))
    elif _max_of(x.dtype) > float(np.finfo(dt).max):
        bounds = (-float(np.finfo(dt).max), float(np.finfo(dt).max))
    count = 0
    if bounds is not None:
        out = (x < bounds[0]) | (x > bounds[1])
        if x.dtype.kind == "f":
            out &= np.isfinite(x)  # infinities stay infinities in a float target
        count = int(out.sum() if valid is None else (out & valid).sum())
        if count and not clip:
            raise OptionError(
                f"expected values within {dt}'s range {bounds[0]}..{bounds[1]}, "
                f"found {count} outside (pass clip=True to clamp them)"
            )
        if out.any():
            x = x.copy()
            x[out] = np.clip(x[out], bounds[0], bounds[1])
    meta = _meta(vol)
    meta["clipped"] = count
    return vol.replace(data=x.astype(dt), meta=meta)


def mask_special(vol: Volume, fill_value=None) -> Volume:
    """Move NaN, +Inf, -Inf and voxels equal to ``fill_value`` into the mask.

    Masked voxels get a neutral value (the smallest valid value, or 0 when none is valid)
    so that later stages see an ordinary range. ``meta['special']`` records
    ``{'nan', 'posinf', 'neginf', 'nfill'}`` counts, ``'fill'`` (the fill value or None)
    and ``'kinds'``: one code per masked voxel in C order (``KIND_*``), or None when all
    masked voxels are of one kind. :func:`unmask_special` reverses this exactly (NaN is
    restored as the canonical quiet NaN).
    """
    if vol.mask is not None and vol.mask.any():
        raise OptionError("expected a volume without masked voxels, found some: unmask it first")
    d = vol.data
    codes = np.zeros(d.shape, np.uint8)
    if d.dtype.kind == "f":
        codes[np.isnan(d)] = KIND_NAN
        codes[d == np.inf] = KIND_POSINF
        codes[d == -np.inf] = KIND_NEGINF
    fill = None
    if fill_value is not None:
        if not np.isfinite(fill_value):
            raise OptionError(f"expected a finite fill value, found {fill_value!r}")
        fill = fill_value.item() if isinstance(fill_value, np.generic) else fill_value
        if d.dtype.kind in "biu":
            fill = int(fill) if float(fill).is_integer() else float(fill)
            info = np.iinfo(d.dtype) if d.dtype.kind != "b" else np.iinfo(np.uint8)
            hit = d == fill if isinstance(fill, int) and info.min <= fill <= info.max else None
        elif abs(float(fill)) <= float(np.finfo(d.dtype).max):
            fill = d.dtype.type(fill).item()  # the value as stored, so it restores exactly
            hit = d == fill
        else:
            fill, hit = float(fill), None
        if hit is not None:
            codes[hit] = KIND_FILL
    mask = codes != 0
    meta = _meta(vol)
    meta["special"] = _special_record(codes[mask], fill)
    if not mask.any():
        return vol.replace(data=d.copy(), mask=None, meta=meta)
    valid = d[~mask]
    data = d.copy()
    data[mask] = valid.min() if valid.size else 0
    return vol.replace(data=data, mask=mask, meta=meta)


def unmask_special(vol: Volume) -> Volume:
    """Put the special values recorded by :func:`mask_special` back; clear the mask."""
    meta = _meta(vol)
    sp = meta.pop("special", None)
    if vol.mask is None or not vol.mask.any():
        return vol.replace(data=vol.data.copy(), mask=None, meta=meta)
    if sp is None:
        raise FormatError("expected meta['special'] describing the masked voxels, found none")
    kinds = _special_kinds(sp, int(vol.mask.sum()))
    data = vol.data.copy()
    if data.dtype.kind != "f" and np.isin(kinds, (KIND_NAN, KIND_POSINF, KIND_NEGINF)).any():
        raise FormatError(f"expected float voxels to restore NaN/Inf into, found {data.dtype}")
    values = np.zeros(kinds.size, np.float64)
    values[kinds == KIND_NAN] = np.nan
    values[kinds == KIND_POSINF] = np.inf
    values[kinds == KIND_NEGINF] = -np.inf
    if (kinds == KIND_FILL).any():
        fill = np.asarray(sp["fill"]).astype(data.dtype)
        if fill != sp["fill"]:
            raise FormatError(f"expected a fill value {data.dtype} holds, found {sp['fill']!r}")
        values = values.astype(data.dtype)
        values[kinds == KIND_FILL] = fill
    data[vol.mask] = values.astype(data.dtype)
    return vol.replace(data=data, mask=None, meta=meta)


def quantize(vol: Volume, bits: int = 16, *, lo=None, hi=None) -> Volume:
    """Map values linearly to ``bits``-bit unsigned codes: ``q = round((x - lo) / scale)``.

    ``scale = (hi - lo) / (2**bits - 1)`` with ``lo``, ``hi`` the valid range unless given
    (values outside a given range clip to code 0 or the top code). The codes are the
    smallest of uint8/16/32 that holds ``bits``. NaN/Inf first go through
    :func:`mask_special`; masked voxels get code 0. ``meta['quantize']`` records ``bits``,
    ``scale``, ``offset`` (= lo), ``dtype`` (what :func:`dequantize` returns: the input float
    type, float64 for integer input) and ``max_error``, the measured largest
    ``|dequantize(q) - x|`` over valid voxels, taken both before and after the cast to the
    returned type, so that it also bounds a reader that keeps ``q * scale + offset`` in
    float64. It is at most ``scale/2`` plus float rounding for values inside the range.
    A constant volume gets ``scale = 0`` and error 0.
    """
    if not isinstance(bits, (int, np.integer)) or not 1 <= bits <= 32:
        raise OptionError(f"expected bits between 1 and 32, found {bits!r}")
    bits = int(bits)
    if vol.dtype.kind == "f" and not np.isfinite(vol.data[_valid_index(vol)]).all():
        if vol.mask is not None and vol.mask.any():
            raise FormatError("expected NaN/Inf only under the mask, found some outside it")
        vol = mask_special(vol)
    d = np.ascontiguousarray(vol.data)
    valid = None if vol.mask is None else ~vol.mask
    vals = d if valid is None else d[valid]
    lo = (float(vals.min()) if vals.size else 0.0) if lo is None else float(lo)
    hi = (float(vals.max()) if vals.size else lo) if hi is None else float(hi)
    levels = 2**bits - 1
    scale = (hi - lo) / levels
    if not (lo <= hi and math.isfinite(scale)):
        raise OptionError(f"expected a finite range lo <= hi to quantize, found {lo!r}..{hi!r}")
    out_dtype = d.dtype if d.dtype.kind == "f" else np.dtype(np.float64)
    qdtype = np.uint8 if bits <= 8 else np.uint16 if bits <= 16 else np.uint32
    flat, fmask = d.reshape(-1), None if valid is None else valid.reshape(-1)
    q = np.empty(flat.size, qdtype)
    max_err = 0.0
    for s in range(0, flat.size, _CHUNK):
        x = flat[s : s + _CHUNK].astype(np.float64)
        y = np.zeros_like(x)
        if scale > 0:
            np.clip(np.rint((x - lo) / scale), 0, levels, out=y)
        keep = slice(None) if fmask is None else fmask[s : s + _CHUNK]
        if fmask is not None:
            y[~keep] = 0
        q[s : s + _CHUNK] = y
        # the exact expression dequantize evaluates, in float64 and cast to the type it returns
        r = y * scale + lo
        err = np.abs(r - x)
        if out_dtype != np.float64:
            np.maximum(err, np.abs(r.astype(out_dtype).astype(np.float64) - x), out=err)
        err = err[keep]
        if err.size:
            max_err = max(max_err, float(err.max()))
    meta = _meta(vol)
    meta["quantize"] = {
        "bits": bits,
        "scale": scale,
        "offset": lo,
        "dtype": str(out_dtype),
        "max_error": max_err,
    }
    return vol.replace(data=q.reshape(d.shape), meta=meta)


def dequantize(vol: Volume) -> Volume:
    """Map codes back with ``x = q * scale + offset`` (float64), cast to the recorded float
    type; the mask and ``meta['special']`` stay for :func:`unmask_special`."""
    meta = _meta(vol)
    rec = meta.pop("quantize", None)
    if rec is None:
        raise OptionError("expected meta['quantize'] from quantize(), found none")
    if vol.dtype.kind != "u":
        raise FormatError(f"expected unsigned integer codes, found {vol.dtype}")
    x = vol.data.astype(np.float64) * float(rec["scale"]) + float(rec["offset"])
    return vol.replace(data=x.astype(np.dtype(rec["dtype"])), meta=meta)


# --- private ---------------------------------------------------------------------------


def _meta(vol: Volume) -> dict:
    return copy.deepcopy(vol.meta)


def _valid_index(vol: Volume):
    return Ellipsis if vol.mask is None else ~vol.mask


def _require_unmasked(vol: Volume, what: str) -> None:
    if vol.mask is not None and vol.mask.any():
        raise OptionError(f"expected a volume without masked voxels to {what}: unmask it first")


def _bounded_slice(start, stop, n: int, label: str) -> slice:
    """Resolve numpy-style start/stop (None, negatives) and insist on a non-empty range."""
    lo = 0 if start is None else start + n if start < 0 else start
    hi = n if stop is None else stop + n if stop < 0 else stop
    if not 0 <= lo < hi <= n:
        raise FormatError(
            f"{label} of length {n}: expected 0 <= start < stop <= {n}, counting negatives from the end"
        )
    return slice(lo, hi)


def _as_slices(ranges, shape, what: str) -> tuple[slice, ...]:
    if isinstance(ranges, str):
        return parse_ranges(ranges, shape, what=what)
    ranges = tuple(ranges)
    if len(shape) == 4 and len(ranges) == 3:
        ranges = (slice(None),) + ranges
    if len(ranges) != len(shape) or not all(isinstance(s, slice) for s in ranges):
        raise OptionError(f"expected {len(shape)} slices, found {ranges!r}")
    out = []
    for s, n, axis in zip(ranges, shape, _AXIS_NAMES[-len(shape) :], strict=True):
        if s.step not in (None, 1):
            raise OptionError(f"expected {what} slices with step 1, found {s!r} on axis {axis}")
        out.append(_bounded_slice(s.start, s.stop, n, f"{what} {s.start}:{s.stop} on axis {axis}"))
    return tuple(out)


def _spatial_ints(value, name: str) -> tuple[int, int, int]:
    v = np.broadcast_to(np.asarray(value), (3,))
    if v.dtype.kind not in "iu" or (v < 1).any():
        raise OptionError(f"expected a positive integer {name} (or one per axis), found {value!r}")
    return tuple(int(k) for k in v)


def _downsample_taps(n: int, f: int, method: str) -> tuple[np.ndarray, np.ndarray]:
    """Input indices ``(m, taps)`` and weights for each output voxel along one axis."""
    m = -(-n // f)
    if method == "box":
        idx = np.arange(m)[:, None] * f + np.arange(f)
        w = (idx < n).astype(np.float64)
    else:
        c = np.arange(m) * f + (f - 1) / 2
        first = np.ceil(c - f).astype(np.int64)
        idx = first[:, None] + np.arange(int(np.floor(c[0] + f) - first[0]) + 1)
        sigma = f / 3
        w = np.exp(-((idx - c[:, None]) ** 2) / (2 * sigma**2))
        w[(idx < 0) | (idx >= n)] = 0.0
        w /= w.sum(axis=1, keepdims=True)
    return np.clip(idx, 0, n - 1), w


def _resample_taps(n: int, old: float, new: float, order: int):
    span = (n - 1) * old / new
    m = int(math.floor(span + 1e-9 * max(1.0, span))) + 1
    p = np.minimum(np.arange(m) * (new / old), n - 1)
    if order == 0:
        return np.minimum(np.floor(p + 0.5), n - 1).astype(np.int64)[:, None], np.ones((m, 1))
    i0 = np.minimum(np.floor(p).astype(np.int64), max(n - 2, 0))
    frac = p - i0
    return np.stack([i0, np.minimum(i0 + 1, n - 1)], 1), np.stack([1 - frac, frac], 1)


def _apply_taps(x: np.ndarray, idx: np.ndarray, w: np.ndarray, axis: int) -> np.ndarray:
    """Return ``out[.., i, ..] = sum_t w[i, t] * x[.., idx[i, t], ..]`` along ``axis``;
    zero-weight taps are skipped (so an Inf there does not turn into NaN)."""
    shape = [1] * x.ndim
    shape[axis] = idx.shape[0]
    out_shape = list(x.shape)
    out_shape[axis] = idx.shape[0]
    out = np.zeros(out_shape, np.float64)
    for t in range(idx.shape[1]):
        wt = w[:, t].reshape(shape)
        with np.errstate(invalid="ignore"):  # Inf * 0 of a skipped tap is dropped below
            term = np.take(x, idx[:, t], axis=axis) * wt
        out += term if (w[:, t] != 0).all() else np.where(wt != 0, term, 0.0)
    return out


def _back_to(acc: np.ndarray, dtype: np.dtype) -> np.ndarray:
    if dtype.kind == "f":
        return acc.astype(dtype)
    return np.rint(acc).astype(dtype)


def _int_bounds_as_float(it: np.dtype, ft: np.dtype) -> tuple:
    """Smallest and largest values of float type ``ft`` inside integer type ``it``'s range."""
    info, fmax = np.iinfo(it), np.finfo(ft).max
    lo = ft.type(max(float(info.min), -float(fmax)))
    hi = ft.type(min(float(info.max), float(fmax)))
    while int(hi) > info.max:  # int max rounded up to a power of two
        hi = np.nextafter(hi, ft.type(0))
    while int(lo) < info.min:
        lo = np.nextafter(lo, ft.type(0))
    return lo, hi


def _max_of(dt: np.dtype) -> float:
    return float(np.finfo(dt).max if dt.kind == "f" else np.iinfo(dt).max)


def _special_record(kinds: np.ndarray, fill) -> dict:
    counts = np.bincount(kinds, minlength=5)
    rec = {key: int(counts[code]) for code, key in _KIND_KEYS.items()}
    rec["fill"] = fill
    rec["kinds"] = kinds.astype(np.uint8) if np.count_nonzero(counts) > 1 else None
    return rec


def _special_kinds(sp: dict, nmasked: int) -> np.ndarray:
    """Return the kind code of every masked voxel (C order) from a special record."""
    counts = {code: int(sp.get(key, 0)) for code, key in _KIND_KEYS.items()}
    if sum(counts.values()) != nmasked:
        raise FormatError(
            f"expected {nmasked} special values for the masked voxels, found {sum(counts.values())}"
        )
    if sp.get("kinds") is not None:
        kinds = np.asarray(sp["kinds"], dtype=np.uint8).reshape(-1)
        found = np.bincount(kinds, minlength=5)
        if kinds.size != nmasked or any(found[c] != k for c, k in counts.items()):
            raise FormatError("expected meta['special']['kinds'] to match the recorded counts")
        return kinds
    present = [c for c, k in counts.items() if k]
    if len(present) != 1:
        raise FormatError("expected meta['special']['kinds'] for a mix of special values")
    return np.full(nmasked, present[0], np.uint8)
