"""Point and cell data of a mesh: prediction along the traversal, 4-bit package coding.

Each field (scalar, vector or tensor; every component on its own) is turned into int64
values and coded in the order the connectivity coder visits its elements (seed-004
§10.8: attached data travel in the same stream order as the elements that create them):

* integers and booleans: the values themselves (64-bit ones wrap, exactly);
* floats, exactly (the default): their ordered bit patterns (integer order is float
  order, so a near prediction gives a small difference; NaN and Inf pass through);
* floats with a bound ``max_error``: ``round((x - offset) / step)`` with
  ``step = 2 max_error``; the bound is checked on every value after the cast back to the
  field's dtype (the step shrinks until it holds).

A value is predicted from already coded ones: a vertex from the three vertices of the
gate it came through (the floor of their mean), a tet from the tet across its gate
(``tet_parent``), anything else from the previous element. Residuals go to the 4-bit
package coder (:mod:`.packages`), one model class per component, with the previous
residual's size as context. Material ids of meshes that are mostly constant cost well
under a bit per tet.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from ..errors import FormatError, OptionError
from . import packages as pk
from .packages import from_ordered_bits, ordered_bits

__all__ = ["encode_attribute", "decode_attribute", "cell_refs"]

N_CTX = 17  # previous residual's package count, 0..16
MAX_CLASSES = 16


def cell_refs(tet_parent: np.ndarray) -> np.ndarray:
    """Prediction references of tets: the parent tet, as an ``(nt, 3)`` array."""
    p = np.asarray(tet_parent, dtype=np.int64).reshape(-1)
    refs = np.full((p.size, 3), -1, dtype=np.int64)
    refs[:, 0] = p
    return refs


def encode_attribute(
    values: np.ndarray, refs: np.ndarray, *, max_error: float | None = None
) -> tuple[bytes, dict]:
    """Code one field given in coding order.

    Parameters
    ----------
    values : ndarray of shape (n, ...)
        Numbers (bool, int, uint or float of 2, 4 or 8 bytes).
    refs : ndarray of shape (n, 3), int
        Rows each row is predicted from (all smaller than the row; -1 unused).
    max_error : float, optional
        For floats: the largest error allowed; ``None`` or 0 keeps them exactly.

    Returns
    -------
    data : bytes
    meta : dict
        What :func:`decode_attribute` needs (dtype, shape, mode, offset, step) plus
        ``max_error``, the largest error actually made.
    """
    a = np.ascontiguousarray(values)
    n = a.shape[0]
    flat = a.reshape(n, int(np.prod(a.shape[1:], dtype=np.int64)))
    meta: dict = {"dtype": a.dtype.str, "shape": list(a.shape[1:])}
    if a.dtype.kind == "f" and max_error:
        q = _bounded(flat, float(max_error), meta)
        if q is None:
            vals = ordered_bits(flat)
            meta.update(mode="exact", max_error=0.0)
    else:
        q = None
        vals = _to_int(flat)
        meta.update(mode="exact", max_error=0.0)
    if q is not None:
        vals = q
    width = _width(meta, a.dtype, vals)
    meta["width"] = width
    r = _check_refs(refs, n)
    for guess in (vals.size + 64, pk.worst_case_bytes(vals.size, width)):
        out = np.empty(guess, dtype=np.uint8)
        used = _encode_kernel(vals, r, width, out)
        if used >= 0:
            return out[:used].tobytes(), meta
    raise AssertionError("attribute coder overflowed its worst-case buffer")


def decode_attribute(data: bytes, meta: dict, refs: np.ndarray) -> np.ndarray:
    """Decode a field coded by :func:`encode_attribute` (coding order)."""
    try:
        dtype = np.dtype(meta["dtype"])
        shape = tuple(int(s) for s in meta["shape"])
        mode = meta["mode"]
        width = int(meta["width"])
        if dtype.kind not in "biuf" or mode not in ("exact", "bounded") or not 1 <= width <= 16:
            raise ValueError((dtype, mode, width))
        if mode == "bounded":
            step, offset = float(meta["step"]), float(meta["offset"])
        ncomp = int(np.prod(shape, dtype=np.int64))
        if ncomp < 1 or ncomp > 1 << 16:
            raise ValueError(shape)
    except (KeyError, TypeError, ValueError, OverflowError) as e:
        raise FormatError(f"bad attribute parameters in the mesh header: {e!r}") from None
    r = _check_refs(refs, len(refs))
    n = len(r)
    vals = np.empty((n, ncomp), dtype=np.int64)
    buf = np.frombuffer(data, dtype=np.uint8)
    if n and vals.size > 8 * 800 * (buf.size + 8):  # each value costs a decision or more
        raise FormatError(
            f"corrupt attribute stream: {buf.size} bytes cannot hold {vals.size} values"
        )
    status = _decode_kernel(buf, r, width, vals) if n else 0
    pk.check_status(status, "attribute")
    if mode == "bounded":
        out = (offset + vals * step).astype(dtype)
    elif dtype.kind == "f":
        out = from_ordered_bits(vals, dtype)
    else:
        out = _from_int(vals, dtype)
    return out.reshape((n, *shape))


def _to_int(flat: np.ndarray) -> np.ndarray:
    if flat.dtype.kind == "b":
        return flat.astype(np.int64)
    if flat.dtype.kind == "f":
        return ordered_bits(flat)
    if flat.dtype == np.uint64:
        return flat.view(np.int64).astype(np.int64)
    return flat.astype(np.int64)


def _from_int(vals: np.ndarray, dtype: np.dtype) -> np.ndarray:
    if dtype.kind == "b":
        return vals != 0
    if dtype == np.uint64:
        return vals.view(np.uint64).astype(dtype)
    return vals.astype(dtype)


def _width(meta: dict, dtype: np.dtype, vals: np.ndarray) -> int:
    if meta["mode"] == "bounded":
        top = int(np.abs(vals).max(initial=0))
        return pk.packages_for_bits(top.bit_length() + 1)
    if dtype.kind == "b":
        return 1
    return pk.packages_for_bits(min(64, 8 * dtype.itemsize))


def _bounded(flat: np.ndarray, max_error: float, meta: dict) -> np.ndarray | None:
    """Quantise with a checked bound; ``None`` when that cannot work (then: exact)."""
    if max_error < 0 or not np.isfinite(max_error):
        raise OptionError(f"expected a finite max error >= 0, found {max_error!r}")
    x = flat.astype(np.float64)
    if not np.isfinite(x).all():
        raise FormatError(
            "a field with NaN or Inf cannot be coded with an error bound; drop the bound"
        )
    if x.size == 0:
        meta.update(mode="bounded", offset=0.0, step=2 * max_error, max_error=0.0)
        return np.zeros(flat.shape, dtype=np.int64)
    offset = float(x.min())
    step = 2.0 * max_error
    for _ in range(8):
        if (float(x.max()) - offset) / step > 2.0**60:
            return None
        q = np.rint((x - offset) / step).astype(np.int64)
        back = (offset + q * step).astype(flat.dtype).astype(np.float64)
        err = float(np.abs(back - x).max())
        if err <= max_error:
            meta.update(mode="bounded", offset=offset, step=step, max_error=err)
            return q
        step *= 0.9  # rounding in the cast back: a little finer grid
    return None


def _check_refs(refs: np.ndarray, n: int) -> np.ndarray:
    r = np.ascontiguousarray(refs, dtype=np.int64).reshape(-1, 3)
    if len(r) != n:
        raise FormatError(f"expected {n} reference rows, found {len(r)}")
    if n and ((r >= np.arange(n)[:, None]) | (r < -1)).any():
        raise FormatError("expected every prediction reference to precede its row")
    return r


# --- kernels (numba) --------------------------------------------------------------------


@kernel(inline=True)
def _predict(vals, refs, i, c):
    """Floor of the mean of the reference rows' values (no overflow); else the row above."""
    s = np.int64(0)
    rem = np.int64(0)
    m = 0
    for q in range(3):
        j = refs[i, q]
        if j >= 0:
            m += 1
    if m == 0:
        return vals[i - 1, c] if i > 0 else np.int64(0)
    for q in range(3):
        j = refs[i, q]
        if j >= 0:
            v = vals[j, c]
            s += v // m
            rem += v % m
    return s + rem // m


@kernel(inline=True)  # numba IR inlining: the kernels compile as if written out
def _coder_state(nc):
    """What encoder and decoder start from alike: the residual models of each class
    (channels past MAX_CLASSES share the last) and each channel's previous count."""
    ncls = min(nc, MAX_CLASSES)
    models = np.full(
        ncls * (N_CTX * pk.N_COUNT + 17 * 16 + 17 * 256), pk.STATE_INIT, dtype=np.uint16
    )
    return models, np.zeros(nc, dtype=np.int64)


@kernel
def _encode_kernel(vals, refs, width, out):
    n, nc = vals.shape
    models, prev = _coder_state(nc)
    cs = pk.start_encoder(out)
    cap = out.size
    for i in range(n):
        if cs[2] + nc * (5 + 4 * width) * 2 + 16 > cap:
            return -1
        for c in range(nc):
            r = vals[i, c] - _predict(vals, refs, i, c)
            prev[c] = pk.put_residual(cs, out, models, N_CTX, min(c, MAX_CLASSES - 1), prev[c], r)
    if cs[2] + 8 > cap:
        return -1
    return pk.finish_encoder(cs, out)


@kernel
def _decode_kernel(data, refs, width, vals):
    n, nc = vals.shape
    models, prev = _coder_state(nc)
    cs = pk.start_decoder(data)
    for i in range(n):
        if cs[2] > data.size + 4:
            return 1
        for c in range(nc):
            r, cnt, ok = pk.get_residual(
                cs, data, models, N_CTX, min(c, MAX_CLASSES - 1), prev[c], width
            )
            if not ok:
                return 2
            vals[i, c] = _predict(vals, refs, i, c) + r
            prev[c] = cnt
    return pk.end_status(data, cs[0], cs[2])  # ends where the encoder's bytes end
