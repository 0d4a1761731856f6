"""Vertex coordinates: quantisation, prediction from the gate, 4-bit package coding.

Vertices are coded in the order the connectivity coder introduces them (seed-004 §10.8,
§10.9), after the connectivity, so the decoder knows every tet when it decodes the
coordinates. A vertex ``k`` is predicted from the triangles it sees: every face
``(a, b, c)`` opposite ``k`` in a tet, with ``a, b, c < k`` and the tet on the face's
other side having its fourth vertex ``w < k`` too. For each such face the prediction is
the apex of a regular tetrahedron on it, on the side away from ``w``:
``centre + 0.816 L n`` with ``L`` the mean edge and ``n`` the unit normal. The gate
through which ``k`` arrived is one of these faces; the predictions of all of them are
averaged. (The thesis predicts the gate centre only; the apex removes the bias along the
normal, and averaging over the faces already known halves the spread.) Vertices that see
no face (the first tet, new components, unreferenced vertices) are predicted by the
previous vertex.

The residual is turned into the frame of the (mean) face normal by two exactly
invertible integer rotations (lifting shears), as in the thesis, and coded by the 4-bit
package coder (:mod:`.packages`) with one model class for the two in-plane axes and one
for the normal, and the face size in bits as context.

Two modes:

``quantized``
    every coordinate is rounded to a grid of ``2**bits`` steps (16 bits by default) over
    the bounding box's diagonal, as in the thesis (one step for all axes, so the gate
    geometry keeps its shape); the
    predictor works on the same integers the decoder has, so nothing drifts. The error
    is at most half a step per coordinate.
``lossless``
    float32/float64 coordinates come back bit for bit: the prediction is made in
    floats, and the residual is the difference of the two numbers' ordered bit
    patterns (an integer count of representable floats; NaN and Inf pass through).
    When it is smaller, the stream instead holds ``lossless-xor``: each vertex's bit
    patterns XOR the previous vertex's, compressed by zstd. That wins on coordinates
    that repeat exactly, as on structured or CAD grids (a 12 x smaller box_with_dent).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel
from ..errors import FormatError
from . import packages as pk
from .mesh import FACES
from .packages import from_ordered_bits, ordered_bits

__all__ = ["encode_geometry", "decode_geometry", "prediction_faces"]

APEX = 0.55  # tuned on the bench meshes (the regular-tet height, 0.816, overshoots on average)
N_CTX = 66  # count contexts: face size in bits (0..64), 65 = no face
_CLASS = np.array([0, 0, 1], dtype=np.int64)  # model class per coded axis: in-plane, normal
MODES = {"quantized": 0, "lossless": 1, "lossless-xor": 2}


def prediction_faces(tets: np.ndarray, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """The faces each vertex is predicted from (see the module docstring).

    Returns ``ptr`` (``nv + 1``) and ``quads`` (``(m, 4)``: ``a, b, c, w``): the faces
    of vertex ``k`` are ``quads[ptr[k]:ptr[k + 1]]``. ``tets`` are in coding order.
    """
    from .mesh import face_adjacency

    t = np.ascontiguousarray(tets, dtype=np.int64).reshape(-1, 4)
    if t.size and (t.min() < 0 or t.max() >= nv):
        raise FormatError(f"expected tet vertex indices in 0..{nv - 1}")
    adj, _ = face_adjacency(t)
    return _prediction_faces_kernel(t, adj, nv)


def encode_geometry(
    points: np.ndarray,
    tets: np.ndarray,
    *,
    bits: int = 16,
    lossless: bool = False,
) -> tuple[bytes, dict]:
    """Code vertex coordinates given in coding order.

    Parameters
    ----------
    points : ndarray of shape (nv, 3), float32 or float64
        Coordinates in coding order.
    tets : ndarray of shape (nt, 4), int
        The tets in coding order, vertices numbered in coding order.
    bits : int
        Quantisation bits per coordinate (1..30) unless ``lossless``.

    Returns
    -------
    data : bytes
    meta : dict
        JSON-ready parameters :func:`decode_geometry` needs (mode, dtype, bits, origin,
        step) plus ``max_error``, the largest coordinate error (0 when lossless).
    """
    pts = np.ascontiguousarray(points)
    if pts.dtype not in (np.float32, np.float64) or pts.ndim != 2 or pts.shape[1] != 3:
        raise ValueError(
            f"expected float32/float64 points of shape (nv, 3), found {pts.dtype} {pts.shape}"
        )
    nv = len(pts)
    ptr, quads = prediction_faces(tets, nv)
    meta: dict = {"dtype": pts.dtype.str}
    if lossless:
        meta.update(mode="lossless", max_error=0.0)
        vals = ordered_bits(pts)
        xyz = pts.astype(np.float64)
        mode = 1 if pts.dtype == np.float64 else 2
        width = pk.packages_for_bits(64 if mode == 1 else 32)
        origin, step = np.zeros(3), 1.0
    else:
        if not 1 <= int(bits) <= 30:
            raise ValueError(f"expected --bits in 1..30, found {bits!r}")
        if nv and not np.isfinite(pts).all():
            raise FormatError(
                "vertex coordinates hold NaN or Inf: expected finite values for quantisation "
                "(use --lossless-geometry)"
            )
        p64 = pts.astype(np.float64)
        origin = p64.min(axis=0) if nv else np.zeros(3)
        extent = float(np.linalg.norm(p64.max(axis=0) - origin)) if nv else 0.0
        step = extent / ((1 << bits) - 1) if extent > 0 else 1.0
        vals = np.clip(np.rint((p64 - origin) / step), 0, (1 << bits) - 1).astype(np.int64)
        xyz = vals.astype(np.float64)
        mode, width = 0, pk.packages_for_bits(bits + 1)  # rotated: up to sqrt(3) longer
        back = dequantize(vals, origin, step, pts.dtype)
        err = float(np.abs(back.astype(np.float64) - p64).max()) if nv else 0.0
        meta.update(
            mode="quantized", bits=int(bits), origin=origin.tolist(), step=step, max_error=err
        )
    for guess in (2 * nv + 64, pk.worst_case_bytes(3 * nv, width)):
        out = np.empty(guess, dtype=np.uint8)
        used = _encode_kernel(vals, xyz, ptr, quads, mode, int(bits), width, out)
        if used >= 0:
            break
    else:
        raise AssertionError("geometry coder overflowed its worst-case buffer")
    data = out[:used].tobytes()
    if lossless:  # coordinates that repeat exactly (grids, CAD) favour a dictionary coder
        xor = _encode_xor(pts)
        if len(xor) < len(data):
            meta["mode"] = "lossless-xor"
            return xor, meta
    return data, meta


def decode_geometry(data: bytes, meta: dict, tets: np.ndarray, nv: int) -> np.ndarray:
    """Decode coordinates coded by :func:`encode_geometry` (coding order, original dtype)."""
    try:
        dtype = np.dtype(meta["dtype"])
        mode_name = meta["mode"]
        mode = MODES[mode_name]
        if dtype not in (np.float32, np.float64):
            raise ValueError(dtype)
        bits = int(meta.get("bits", 0))
        if mode == 0:
            origin = np.asarray(meta["origin"], dtype=np.float64).reshape(3)
            step = float(meta["step"])
            if not 1 <= bits <= 30:
                raise ValueError(bits)
    except (KeyError, TypeError, ValueError) as e:
        raise FormatError(f"bad geometry parameters in the mesh header: {e!r}") from None
    if mode == 2:
        return _decode_xor(data, dtype, nv)
    ptr, quads = prediction_faces(tets, nv)
    if mode == 1:
        mode = 1 if dtype == np.float64 else 2
        width = pk.packages_for_bits(64 if mode == 1 else 32)
    else:
        width = pk.packages_for_bits(bits + 1)
    buf = np.frombuffer(data, dtype=np.uint8)
    if buf.size < 1 and nv:
        raise FormatError("corrupt geometry stream: it is empty")
    vals = np.empty((nv, 3), dtype=np.int64)
    xyz = np.empty((nv, 3), dtype=np.float64)
    status = _decode_kernel(buf, ptr, quads, mode, bits, width, vals, xyz) if nv else 0
    pk.check_status(status, "geometry")
    if mode == 0:
        return dequantize(vals, origin, step, dtype)
    return from_ordered_bits(vals, dtype)


def _encode_xor(pts: np.ndarray) -> bytes:
    """Each vertex's bit patterns XOR the previous vertex's, then zstd."""
    import zstandard

    bits = pts.view(f"<u{pts.itemsize}")
    x = bits.copy()
    x[1:] ^= bits[:-1]
    return zstandard.ZstdCompressor(level=9).compress(x.tobytes())


def _decode_xor(data: bytes, dtype: np.dtype, nv: int) -> np.ndarray:
    import zstandard

    need = nv * 3 * dtype.itemsize
    try:
        raw = zstandard.ZstdDecompressor().decompress(data, max_output_size=need)
    except zstandard.ZstdError as e:
        raise FormatError(f"corrupt geometry stream: {e}") from None
    if len(raw) != need:
        raise FormatError(f"corrupt geometry stream: expected {need} bytes, found {len(raw)}")
    x = np.frombuffer(raw, dtype=f"<u{dtype.itemsize}").reshape(nv, 3)
    return np.bitwise_xor.accumulate(x, axis=0).view(dtype.newbyteorder("<")).astype(dtype)


def dequantize(q: np.ndarray, origin: np.ndarray, step: float, dtype) -> np.ndarray:
    """Grid integers back to coordinates."""
    return (np.asarray(origin, dtype=np.float64) + q * float(step)).astype(dtype)


# --- kernels (numba) --------------------------------------------------------------------


@kernel
def _prediction_faces_kernel(t, adj, nv):
    cnt = np.zeros(nv + 1, dtype=np.int64)
    for pass_ in range(2):
        if pass_ == 1:
            for k in range(nv):
                cnt[k + 1] += cnt[k]
            quads = np.empty((cnt[nv], 4), dtype=np.int64)
            fill = cnt[:nv].copy()
        for j in range(t.shape[0]):
            for i in range(4):
                k = t[j, i]
                a = t[j, FACES[i, 0]]
                b = t[j, FACES[i, 1]]
                c = t[j, FACES[i, 2]]
                if a > k or b > k or c > k:
                    continue
                j2 = adj[j, i]
                if j2 < 0:
                    continue
                w = -1
                for q in range(4):
                    v = t[j2, q]
                    if v != a and v != b and v != c:
                        w = v
                if w < 0 or w > k:
                    continue
                if pass_ == 0:
                    cnt[k + 1] += 1
                else:
                    f = fill[k]
                    quads[f, 0] = a
                    quads[f, 1] = b
                    quads[f, 2] = c
                    quads[f, 3] = w
                    fill[k] = f + 1
    return cnt, quads


@kernel
def _predict(xyz, k, ptr, quads, pred, normal):
    """Fill ``pred`` with the predicted position of vertex k and ``normal`` with the mean
    unit normal of its faces (zeros when unknown); return the mean face edge length L
    (-1 when vertex k sees no face)."""
    for ax in range(3):
        pred[ax] = 0.0
        normal[ax] = 0.0
    m = ptr[k + 1] - ptr[k]
    if m == 0:
        for ax in range(3):
            pred[ax] = xyz[k - 1, ax] if k > 0 else 0.0
        return -1.0
    lsum = 0.0
    for f in range(ptr[k], ptr[k + 1]):
        a = quads[f, 0]
        b = quads[f, 1]
        c = quads[f, 2]
        w = quads[f, 3]
        e10 = xyz[b, 0] - xyz[a, 0]
        e11 = xyz[b, 1] - xyz[a, 1]
        e12 = xyz[b, 2] - xyz[a, 2]
        e20 = xyz[c, 0] - xyz[a, 0]
        e21 = xyz[c, 1] - xyz[a, 1]
        e22 = xyz[c, 2] - xyz[a, 2]
        n0 = e11 * e22 - e12 * e21
        n1 = e12 * e20 - e10 * e22
        n2 = e10 * e21 - e11 * e20
        l1 = math.sqrt(e10 * e10 + e11 * e11 + e12 * e12)
        l2 = math.sqrt(e20 * e20 + e21 * e21 + e22 * e22)
        l3 = math.sqrt((e20 - e10) ** 2 + (e21 - e11) ** 2 + (e22 - e12) ** 2)
        ln = (l1 + l2 + l3) / 3.0
        lsum += ln
        c0 = (xyz[a, 0] + xyz[b, 0] + xyz[c, 0]) / 3.0
        c1 = (xyz[a, 1] + xyz[b, 1] + xyz[c, 1]) / 3.0
        c2 = (xyz[a, 2] + xyz[b, 2] + xyz[c, 2]) / 3.0
        nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if nn > 0.0:
            side = n0 * (xyz[w, 0] - c0) + n1 * (xyz[w, 1] - c1) + n2 * (xyz[w, 2] - c2)
            h = (-APEX if side > 0.0 else APEX) * ln / nn
            n0 *= h
            n1 *= h
            n2 *= h
        else:
            n0 = 0.0
            n1 = 0.0
            n2 = 0.0
        pred[0] += c0 + n0
        pred[1] += c1 + n1
        pred[2] += c2 + n2
        normal[0] += n0
        normal[1] += n1
        normal[2] += n2
    nn = math.sqrt(normal[0] ** 2 + normal[1] ** 2 + normal[2] ** 2)
    for ax in range(3):
        pred[ax] /= m
        normal[ax] = normal[ax] / nn if nn > 0.0 else 0.0
    return lsum / m


@kernel
def _lift_angles(normal):
    """Angles of the two plane rotations that turn ``normal`` onto the z axis: by -phi in
    the (x, y) plane, then by theta in the (x, z) plane."""
    if normal[0] == 0.0 and normal[1] == 0.0 and normal[2] == 0.0:
        return 0.0, 0.0
    phi = math.atan2(normal[1], normal[0])
    theta = math.acos(min(1.0, max(-1.0, normal[2])))
    return -phi, theta


@kernel
def _rotate(r, i, j, ang, inverse):
    """Rotate the integer pair (r[i], r[j]) by ``ang`` exactly invertibly: three lifting
    shears with rounding (a half turn, which is exact, first when |ang| > pi/2)."""
    half = False
    if ang > 0.5 * math.pi:
        ang -= math.pi
        half = True
    elif ang < -0.5 * math.pi:
        ang += math.pi
        half = True
    p = -math.tan(0.5 * ang)
    s = math.sin(ang)
    x = r[i]
    y = r[j]
    if not inverse:
        if half:
            x = -x
            y = -y
        x += np.int64(math.floor(p * y + 0.5))
        y += np.int64(math.floor(s * x + 0.5))
        x += np.int64(math.floor(p * y + 0.5))
    else:
        x -= np.int64(math.floor(p * y + 0.5))
        y -= np.int64(math.floor(s * x + 0.5))
        x -= np.int64(math.floor(p * y + 0.5))
        if half:
            x = -x
            y = -y
    r[i] = x
    r[j] = y


@kernel
def _to_int(x, mode, bits, f64, i64, f32, i32):
    """The integer the predicted coordinate ``x`` stands for in the coded domain."""
    if mode == 0:
        if not x >= 0.0:  # also NaN
            return np.int64(0)
        hi = np.int64((1 << bits) - 1)
        if x >= hi:
            return hi
        return np.int64(math.floor(x + 0.5))
    if mode == 1:
        f64[0] = x
        b = i64[0]
        return b ^ ((b >> 63) & np.int64(0x7FFFFFFFFFFFFFFF))
    f32[0] = x
    b = np.int64(i32[0])
    return b ^ ((b >> 31) & np.int64(0x7FFFFFFF))


@kernel
def _context(mode, ln, p, bits, f64, i64, f32, i32):
    """Count context: the face size in the coded domain's units, in bits."""
    if ln < 0.0:
        return N_CTX - 1
    if mode == 0:
        d = np.int64(ln) if ln < 1e18 else np.int64(1 << 60)
    else:
        d = _to_int(p + ln, mode, bits, f64, i64, f32, i32) - _to_int(
            p, mode, bits, f64, i64, f32, i32
        )
        if d < 0:
            d = -d
    n = 0
    while d > 0:
        n += 1
        d >>= 1
    return min(n, N_CTX - 2)


@kernel
def _encode_kernel(vals, xyz, ptr, quads, mode, bits, width, out):
    nv = vals.shape[0]
    models = np.full(3 * (N_CTX * pk.N_COUNT + 17 * 16 + 17 * 256), pk.STATE_INIT, dtype=np.uint16)
    cs = pk.start_encoder(out)
    pred = np.empty(3)
    f64 = np.empty(1, dtype=np.float64)
    i64 = f64.view(np.int64)
    f32 = np.empty(1, dtype=np.float32)
    i32 = f32.view(np.int32)
    cap = out.size
    normal = np.empty(3)
    res = np.empty(3, dtype=np.int64)
    for k in range(nv):
        if cs[2] + 3 * (5 + 4 * width) * 2 + 16 > cap:
            return -1
        ln = _predict(xyz, k, ptr, quads, pred, normal)
        for ax in range(3):
            res[ax] = vals[k, ax] - _to_int(pred[ax], mode, bits, f64, i64, f32, i32)
        if mode == 0:  # into the gate's frame: z along the normal (seed-004 §10.9 step 4)
            a1, a2 = _lift_angles(normal)
            _rotate(res, 0, 1, a1, False)
            _rotate(res, 0, 2, a2, False)
        for ax in range(3):
            ctx = _context(mode, ln, pred[ax], bits, f64, i64, f32, i32)
            pk.put_residual(cs, out, models, N_CTX, _CLASS[ax], ctx, res[ax])
    if cs[2] + 8 > cap:
        return -1
    return pk.finish_encoder(cs, out)


@kernel
def _decode_kernel(data, ptr, quads, mode, bits, width, vals, xyz):
    """Return 0, or 1 when the stream ran short, 2 on an impossible value."""
    nv = vals.shape[0]
    models = np.full(3 * (N_CTX * pk.N_COUNT + 17 * 16 + 17 * 256), pk.STATE_INIT, dtype=np.uint16)
    cs = pk.start_decoder(data)
    pred = np.empty(3)
    f64 = np.empty(1, dtype=np.float64)
    i64 = f64.view(np.int64)
    f32 = np.empty(1, dtype=np.float32)
    i32 = f32.view(np.int32)
    hi = np.int64((1 << bits) - 1) if mode == 0 else np.int64(0)
    normal = np.empty(3)
    res = np.empty(3, dtype=np.int64)
    for k in range(nv):
        if cs[2] > data.size + 4:
            return 1
        ln = _predict(xyz, k, ptr, quads, pred, normal)
        for ax in range(3):
            ctx = _context(mode, ln, pred[ax], bits, f64, i64, f32, i32)
            r, n, ok = pk.get_residual(cs, data, models, N_CTX, _CLASS[ax], ctx, width)
            if not ok:
                return 2
            res[ax] = r
        if mode == 0:
            a1, a2 = _lift_angles(normal)
            _rotate(res, 0, 2, a2, True)
            _rotate(res, 0, 1, a1, True)
        for ax in range(3):
            v = _to_int(pred[ax], mode, bits, f64, i64, f32, i32) + res[ax]
            vals[k, ax] = v
            if mode == 0:
                if v < 0 or v > hi:
                    return 2
                xyz[k, ax] = np.float64(v)
            elif mode == 1:
                i64[0] = v ^ ((v >> 63) & np.int64(0x7FFFFFFFFFFFFFFF))
                xyz[k, ax] = f64[0]
            else:
                if v < -(1 << 31) or v >= (1 << 31):
                    return 2
                i32[0] = np.int32(v ^ ((v >> 31) & np.int64(0x7FFFFFFF)))
                xyz[k, ax] = np.float64(f32[0])
    if cs[2] != data.size:  # the decoder ends exactly where the encoder's bytes end
        return 1
    return 0
