"""Vertex coordinates: quantisation, prediction from the gate, scaled residual coding.

Vertices are coded in the order the connectivity coder introduces them (seed-004 §10.8,
§10.9), after the connectivity, so the decoder knows every tet when it decodes the
coordinates. A vertex ``k`` is predicted from what is decoded around it:

* **Faces.** Every face ``(a, b, c)`` opposite ``k`` in a tet, with ``a, b, c < k`` and
  the tet on the face's other side having its fourth vertex ``w < k`` too. The gate
  through which ``k`` arrived is one of them. From their mean centre ``g``, their mean
  unit normal ``n`` (pointing away from ``w``), their mean edge ``L`` and the mean of
  ``d n_f`` (``d`` the distance of ``w`` from face ``f``: a thick tet behind the face
  makes a thick one in front), the apex prediction is ``g + h1 L n + h2 mean(d n_f)``.
  The heights ``h1, h2`` are learnt backwards, by least squares over the vertices
  already decoded (the thesis predicts the gate centre only; the apex removes the bias
  along the normal, and averaging over the faces already known halves the spread).
  Structured grids are better served by the mean reflection of the ``w`` through the
  faces: the cheaper of the two lately (counted in bits) predicts.
* **Border.** A border vertex (on a face with no tet behind it) whose border neighbours
  are decoded lies, like them, on the border surface: the prediction is moved onto the
  plane through their mean, normal to the mean of their border normals. On planar
  patches (boxes, cut planes) the residual along that normal is then zero; such flat
  neighbourhoods get their own scale and models. On a crease, where two flat patches
  meet (a box's edge), the prediction goes to the line of the two planes instead, and
  the frame's z axis along it. Across each decoded border edge the
  vertex also completes a parallelogram with the border triangle on the other side; the
  cheapest lately of the projected apex, the (projected) mean parallelogram and their
  mean predicts.
* Vertices that see no face (the first tet, new components, unreferenced vertices) are
  predicted by the previous vertex.

The residual is turned into the frame of the normal (the border plane's, else the
faces') by two exactly invertible integer rotations (lifting shears), as in the thesis,
and each component is coded by :func:`.packages.put_scaled`: its bit length relative to
an estimate ``mean |residual| / L`` (learnt per axis and kind of vertex) times ``L``,
two adaptive bits below the leading one, the rest raw.

Two modes:

``quantized``
    every coordinate is rounded to a grid of ``2**bits`` steps (16 bits by default) over
    the bounding box's diagonal, as in the thesis (one step for all axes, so the gate
    geometry keeps its shape); the
    predictor works on the same integers the decoder has, so nothing drifts. The error
    is at most half a step per coordinate.
``lossless``
    float32/float64 coordinates come back bit for bit: the prediction is made in
    floats (no rotation), and the residual is the difference of the two numbers'
    ordered bit patterns (an integer count of representable floats; NaN and Inf pass
    through).
    When it is smaller, the stream instead holds ``lossless-xor``: each vertex's bit
    patterns XOR the previous vertex's, compressed by zstd. That wins on coordinates
    that repeat exactly, as on structured or CAD grids (a 12 x smaller box_with_dent).

It stays one file of about 1,000 lines on purpose: the encode and decode kernels run one
vertex model (prediction, learnt heights, border and crease frames, scales) through
shared inline kernels, which must stay the same on both sides.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel, leading_zeros
from ..errors import FormatError, OptionError
from . import packages as pk
from .mesh import FACES
from .packages import from_ordered_bits, ordered_bits

__all__ = ["encode_geometry", "decode_geometry", "prediction_faces"]

_CLASS = np.array([0, 0, 1], dtype=np.int64)  # model class per coded axis: in-plane, normal
MODES = {"quantized": 0, "lossless": 1, "lossless-xor": 2}
CODER = "scaled"  # the residual code (header ``geometry.coder``); streams without it used
# the 4-bit packages of volpack before 2026-11-26 and are refused with that reason


def prediction_faces(tets: np.ndarray, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """The faces each vertex is predicted from (see the module docstring).

    Returns ``ptr`` (``nv + 1``) and ``quads`` (``(m, 4)``: ``a, b, c, w``): the faces
    of vertex ``k`` are ``quads[ptr[k]:ptr[k + 1]]``. ``tets`` are in coding order.
    """
    return _neighbourhood(tets, nv)[:2]


def _neighbourhood(tets: np.ndarray, nv: int, adj: np.ndarray | None = None):
    """What the predictor of each vertex looks at: its faces (:func:`prediction_faces`)
    and the border triangles around it (``bptr``, ``bidx``: the triangles of vertex
    ``k`` are ``btri[bidx[bptr[k]:bptr[k + 1]]]``, rows ``a, b, c, max(a, b, c)``)."""
    from .mesh import face_adjacency

    t = np.ascontiguousarray(tets, dtype=np.int64).reshape(-1, 4)
    if t.size and (t.min() < 0 or t.max() >= nv):
        raise FormatError(f"expected tet vertex indices in 0..{nv - 1}")
    if adj is None:
        adj, _ = face_adjacency(t)
    ptr, quads = _prediction_faces_kernel(t, adj, nv)
    bptr, bidx, btri = _border_kernel(t, adj, nv)
    return ptr, quads, bptr, bidx, btri


def encode_geometry(
    points: np.ndarray,
    tets: np.ndarray,
    *,
    bits: int = 16,
    lossless: bool = False,
    adjacency: np.ndarray | None = None,
) -> tuple[bytes, dict]:
    """Code vertex coordinates given in coding order (``adjacency``: the tets' face
    neighbours when the caller has them, see ``cutborder.Traversal``).

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
        raise OptionError(
            f"expected float32/float64 points of shape (nv, 3), found {pts.dtype} {pts.shape}"
        )
    nv = len(pts)
    hood = _neighbourhood(tets, nv, adjacency)
    meta: dict = {"dtype": pts.dtype.str, "coder": CODER}
    if lossless:
        meta.update(mode="lossless", max_error=0.0)
        vals = ordered_bits(pts)
        xyz = pts.astype(np.float64)
        mode = 1 if pts.dtype == np.float64 else 2
        origin, step = np.zeros(3), 1.0
    else:
        if not 1 <= int(bits) <= 30:
            raise OptionError(f"expected bits in 1..30, found {bits!r}")
        if nv and not np.isfinite(pts).all():
            raise FormatError(
                "vertex coordinates hold NaN or Inf: expected finite values for quantisation "
                "(use lossless_geometry=True)"
            )
        p64 = pts.astype(np.float64)
        origin = p64.min(axis=0) if nv else np.zeros(3)
        extent = float(np.linalg.norm(p64.max(axis=0) - origin)) if nv else 0.0
        step = extent / ((1 << bits) - 1) if extent > 0 else 1.0
        vals = np.clip(np.rint((p64 - origin) / step), 0, (1 << bits) - 1).astype(np.int64)
        xyz = vals.astype(np.float64)
        mode = 0
        back = dequantize(vals, origin, step, pts.dtype)
        err = float(np.abs(back.astype(np.float64) - p64).max()) if nv else 0.0
        meta.update(
            mode="quantized", bits=int(bits), origin=origin.tolist(), step=step, max_error=err
        )
    raw_bits = bits + 2 if mode == 0 else 8 * pts.itemsize + 2  # the raw size first: rarely beaten
    for guess in (3 * nv * raw_bits // 8 + 64, pk.scaled_worst_case_bytes(3 * nv)):
        out = np.empty(guess, dtype=np.uint8)
        used = _encode_kernel(vals, xyz, *hood, mode, int(bits), out)
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
    if meta.get("coder") != CODER:
        raise FormatError(
            f"this mesh stream's coordinates use the coder {meta.get('coder', 'packages')!r} "
            f"of an earlier volpack; this version reads {CODER!r} only (re-encode the mesh "
            "with the volpack that wrote it)"
        )
    hood = _neighbourhood(tets, nv)
    if mode == 1:
        mode = 1 if dtype == np.float64 else 2
    buf = np.frombuffer(data, dtype=np.uint8)
    if buf.size < 1 and nv:
        raise FormatError("corrupt geometry stream: it is empty")
    vals = np.empty((nv, 3), dtype=np.int64)
    xyz = np.empty((nv, 3), dtype=np.float64)
    status = _decode_kernel(buf, *hood, mode, bits, vals, xyz) if nv else 0
    pk.check_status(status, "geometry")
    if mode == 0:
        return dequantize(vals, origin, step, dtype)
    return from_ordered_bits(vals, dtype)


def _encode_xor(pts: np.ndarray) -> bytes:
    """Each vertex's bit patterns XOR the previous vertex's, then zstd."""
    from ..format.deflate import deflate

    bits = pts.view(f"<u{pts.itemsize}")
    x = bits.copy()
    x[1:] ^= bits[:-1]
    return deflate(x.tobytes())


def _decode_xor(data: bytes, dtype: np.dtype, nv: int) -> np.ndarray:
    from ..format.deflate import inflate

    raw = inflate(data, nv * 3 * dtype.itemsize, "geometry stream", exact=True)
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
def _border_kernel(t, adj, nv):
    nb = 0
    for j in range(t.shape[0]):
        for i in range(4):
            if adj[j, i] < 0:
                nb += 1
    btri = np.empty((nb, 4), dtype=np.int64)
    bptr = np.zeros(nv + 1, dtype=np.int64)
    q = 0
    for j in range(t.shape[0]):
        for i in range(4):
            if adj[j, i] < 0:
                top = -1
                for c in range(3):
                    v = t[j, FACES[i, c]]
                    btri[q, c] = v
                    top = max(top, v)
                    bptr[v + 1] += 1
                btri[q, 3] = top
                q += 1
    for k in range(nv):
        bptr[k + 1] += bptr[k]
    fill = bptr[:nv].copy()
    bidx = np.empty(3 * nb, dtype=np.int64)
    for q in range(nb):
        for c in range(3):
            v = btri[q, c]
            bidx[fill[v]] = q
            fill[v] += 1
    return bptr, bidx, btri


@kernel
def _surface(xyz, k, bptr, bidx, btri, vnorm, mark, point, snormal):
    """The border plane vertex k lies on, if it is a border vertex: ``point`` the mean of
    its border neighbours decoded so far, ``snormal`` the sum of their normals (``vnorm``,
    signs made to agree), scaled to unit length. Return the number of those neighbours
    (0 when k sees no border; the plane is unknown under 2)."""
    cnt = 0
    for ax in range(3):
        point[ax] = 0.0
        snormal[ax] = 0.0
    for e in range(bptr[k], bptr[k + 1]):
        q = bidx[e]
        for i in range(3):
            v = btri[q, i]
            if v >= k or mark[v] == k:
                continue
            mark[v] = k
            cnt += 1
            d = 0.0
            for ax in range(3):
                point[ax] += xyz[v, ax]
                d += vnorm[v, ax] * snormal[ax]
            g = -1.0 if d < 0.0 else 1.0
            for ax in range(3):
                snormal[ax] += g * vnorm[v, ax]
    if cnt < 2:
        return 0
    nn = math.sqrt(snormal[0] ** 2 + snormal[1] ** 2 + snormal[2] ** 2)
    if not nn > 0.0:
        return 0
    for ax in range(3):
        point[ax] /= cnt
        snormal[ax] /= nn
    return cnt


@kernel
def _flatness(xyz, k, bptr, bidx, btri, mark, point, snormal):
    """Mean distance of k's decoded border neighbours (as marked by :func:`_surface`)
    from their plane."""
    dev = 0.0
    cnt = 0
    for e in range(bptr[k], bptr[k + 1]):
        q = bidx[e]
        for i in range(3):
            v = btri[q, i]
            if v >= k or mark[v] != k:
                continue
            mark[v] = -2 - k
            cnt += 1
            d = 0.0
            for ax in range(3):
                d += (xyz[v, ax] - point[ax]) * snormal[ax]
            dev += abs(d)
    return dev / cnt if cnt > 0 else 0.0


@kernel
def _crease(xyz, k, bptr, bidx, btri, vnorm, mark, mark2, ln, pred, axis):
    """Vertex k on a crease of the border (a box's edge): its decoded border neighbours
    (as marked by :func:`_flatness`) fall into two groups with one normal each whose
    points lie on their plane. Then move ``pred`` to the nearest point of the two planes'
    line, set ``axis`` to that line and return True."""
    u1x = 0.0
    u1y = 0.0
    u1z = 0.0
    for e in range(bptr[k], bptr[k + 1]):  # the first neighbour's normal is the seed
        q = bidx[e]
        for i in range(3):
            v = btri[q, i]
            if v < k and mark[v] == -2 - k and u1x == 0.0 and u1y == 0.0 and u1z == 0.0:
                nn = math.sqrt(vnorm[v, 0] ** 2 + vnorm[v, 1] ** 2 + vnorm[v, 2] ** 2)
                if nn > 0.0:
                    u1x = vnorm[v, 0] / nn
                    u1y = vnorm[v, 1] / nn
                    u1z = vnorm[v, 2] / nn
    if u1x == 0.0 and u1y == 0.0 and u1z == 0.0:
        return False
    g1 = np.zeros(7)  # normal sum, point sum, count
    g2 = np.zeros(7)
    u2 = np.zeros(3)
    for grp in range(2):
        g = g1 if grp == 0 else g2
        if grp == 0:
            sx, sy, sz = u1x, u1y, u1z
        else:
            sx, sy, sz = u2[0], u2[1], u2[2]
        for e in range(bptr[k], bptr[k + 1]):
            q = bidx[e]
            for i in range(3):
                v = btri[q, i]
                if v >= k or mark[v] != -2 - k or mark2[v] == 2 * k + grp:
                    continue
                mark2[v] = 2 * k + grp
                nn = math.sqrt(vnorm[v, 0] ** 2 + vnorm[v, 1] ** 2 + vnorm[v, 2] ** 2)
                if not nn > 0.0:
                    continue
                d = (vnorm[v, 0] * sx + vnorm[v, 1] * sy + vnorm[v, 2] * sz) / nn
                if abs(d) > CREASE_SAME:
                    sg = 1.0 if d > 0.0 else -1.0
                    for ax in range(3):
                        g[ax] += sg * vnorm[v, ax] / nn
                        g[3 + ax] += xyz[v, ax]
                    g[6] += 1.0
                elif (
                    grp == 0
                    and abs(d) < CREASE_APART
                    and u2[0] == 0.0
                    and u2[1] == 0.0
                    and u2[2] == 0.0
                ):
                    for ax in range(3):
                        u2[ax] = vnorm[v, ax] / nn
        if grp == 0 and u2[0] == 0.0 and u2[1] == 0.0 and u2[2] == 0.0:
            return False
    if g1[6] < 2.0 or g2[6] < 2.0:
        return False
    for g in (g1, g2):
        nn = math.sqrt(g[0] ** 2 + g[1] ** 2 + g[2] ** 2)
        for ax in range(3):
            g[ax] /= nn
            g[3 + ax] /= g[6]
    # every member on its group's plane (else a curved border, not a crease)
    for grp in range(2):
        g = g1 if grp == 0 else g2
        for e in range(bptr[k], bptr[k + 1]):
            q = bidx[e]
            for i in range(3):
                v = btri[q, i]
                if v >= k or mark2[v] != 2 * k + 1:
                    continue
                nn = math.sqrt(vnorm[v, 0] ** 2 + vnorm[v, 1] ** 2 + vnorm[v, 2] ** 2)
                if not nn > 0.0:
                    continue
                d = (vnorm[v, 0] * g[0] + vnorm[v, 1] * g[1] + vnorm[v, 2] * g[2]) / nn
                if abs(d) > CREASE_SAME:
                    off = 0.0
                    for ax in range(3):
                        off += (xyz[v, ax] - g[3 + ax]) * g[ax]
                    if abs(off) > FLAT * ln:
                        return False
    gg = g1[0] * g2[0] + g1[1] * g2[1] + g1[2] * g2[2]
    den = 1.0 - gg * gg
    if not den > 0.01:
        return False
    e1 = 0.0
    e2 = 0.0
    for ax in range(3):
        e1 += (pred[ax] - g1[3 + ax]) * g1[ax]
        e2 += (pred[ax] - g2[3 + ax]) * g2[ax]
    a = (e1 - gg * e2) / den
    b = (e2 - gg * e1) / den
    for ax in range(3):
        pred[ax] -= a * g1[ax] + b * g2[ax]
    axis[0] = g1[1] * g2[2] - g1[2] * g2[1]
    axis[1] = g1[2] * g2[0] - g1[0] * g2[2]
    axis[2] = g1[0] * g2[1] - g1[1] * g2[0]
    nn = math.sqrt(axis[0] ** 2 + axis[1] ** 2 + axis[2] ** 2)
    for ax in range(3):
        axis[ax] /= nn
    return True


@kernel
def _parallelogram(xyz, k, bptr, bidx, btri, par):
    """Mean of ``P[u] + P[v] - P[w]`` over k's border triangles ``(k, u, v)`` with ``u, v <
    k`` and the decoded border triangles ``(u, v, w)`` across their edge ``uv``: on a
    border surface the next vertex completes the parallelogram. Return their number."""
    cnt = 0
    for ax in range(3):
        par[ax] = 0.0
    for e in range(bptr[k], bptr[k + 1]):
        q = bidx[e]
        u = -1
        v = -1
        n = 0
        for i in range(3):
            x = btri[q, i]
            if x != k:
                n += 1
                if u < 0:
                    u = x
                else:
                    v = x
        if n != 2 or u >= k or v >= k:
            continue
        for e2 in range(bptr[u], bptr[u + 1]):
            q2 = bidx[e2]
            if q2 == q:
                continue
            hit = 0
            w = -1
            for i in range(3):
                x = btri[q2, i]
                if x == u or x == v:
                    hit += 1
                else:
                    w = x
            if hit != 2 or w < 0 or w >= k:
                continue
            for ax in range(3):
                par[ax] += xyz[u, ax] + xyz[v, ax] - xyz[w, ax]
            cnt += 1
    if cnt > 0:
        for ax in range(3):
            par[ax] /= cnt
    return cnt


@kernel(inline=True)
def _triangle(xyz, a, b, c):
    """Edges ``b - a`` and ``c - a`` of triangle (a, b, c) and their cross product (the
    unnormalised normal), in that order."""
    e10 = xyz[b, 0] - xyz[a, 0]
    e11 = xyz[b, 1] - xyz[a, 1]
    e12 = xyz[b, 2] - xyz[a, 2]
    e20 = xyz[c, 0] - xyz[a, 0]
    e21 = xyz[c, 1] - xyz[a, 1]
    e22 = xyz[c, 2] - xyz[a, 2]
    n0 = e11 * e22 - e12 * e21
    n1 = e12 * e20 - e10 * e22
    n2 = e10 * e21 - e11 * e20
    return e10, e11, e12, e20, e21, e22, n0, n1, n2


@kernel
def _add_border_normals(xyz, k, bptr, bidx, btri, vnorm):
    """Vertex k is decoded: add the unit normal of each border triangle it completes to
    the normals of its three vertices (signs made to agree with what they hold)."""
    for e in range(bptr[k], bptr[k + 1]):
        q = bidx[e]
        if btri[q, 3] != k:
            continue
        a = btri[q, 0]
        b = btri[q, 1]
        c = btri[q, 2]
        n0, n1, n2 = _triangle(xyz, a, b, c)[6:]
        nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        if not nn > 0.0:
            continue
        n0 /= nn
        n1 /= nn
        n2 /= nn
        for i in range(3):
            v = btri[q, i]
            g = -1.0 if vnorm[v, 0] * n0 + vnorm[v, 1] * n1 + vnorm[v, 2] * n2 < 0.0 else 1.0
            vnorm[v, 0] += g * n0
            vnorm[v, 1] += g * n1
            vnorm[v, 2] += g * n2


@kernel
def _project(pred, point, snormal):
    """Move the prediction onto the border plane along its normal."""
    d = 0.0
    for ax in range(3):
        d += (pred[ax] - point[ax]) * snormal[ax]
    for ax in range(3):
        pred[ax] -= d * snormal[ax]


@kernel
def _predict(xyz, k, ptr, quads, cen, refl, far, normal):
    """Look at the faces vertex k sees: fill ``cen`` with the mean of their centres,
    ``refl`` with the mean reflection of their far vertices ``w`` through their planes,
    ``far`` with the mean of their unit normals (pointing away from ``w``) times the
    distance of ``w`` from the face, and ``normal`` with the mean of their unit normals,
    scaled to unit length (zeros when unknown). Return the mean face edge length L, or
    -1 when vertex k sees no face."""
    for ax in range(3):
        cen[ax] = 0.0
        refl[ax] = 0.0
        far[ax] = 0.0
        normal[ax] = 0.0
    m = ptr[k + 1] - ptr[k]
    if m == 0:
        return -1.0
    lsum = 0.0
    for f in range(ptr[k], ptr[k + 1]):
        a = quads[f, 0]
        b = quads[f, 1]
        c = quads[f, 2]
        w = quads[f, 3]
        e10, e11, e12, e20, e21, e22, n0, n1, n2 = _triangle(xyz, a, b, c)
        l1 = math.sqrt(e10 * e10 + e11 * e11 + e12 * e12)
        l2 = math.sqrt(e20 * e20 + e21 * e21 + e22 * e22)
        l3 = math.sqrt((e20 - e10) ** 2 + (e21 - e11) ** 2 + (e22 - e12) ** 2)
        lsum += (l1 + l2 + l3) / 3.0
        c0 = (xyz[a, 0] + xyz[b, 0] + xyz[c, 0]) / 3.0
        c1 = (xyz[a, 1] + xyz[b, 1] + xyz[c, 1]) / 3.0
        c2 = (xyz[a, 2] + xyz[b, 2] + xyz[c, 2]) / 3.0
        d0 = xyz[w, 0] - c0
        d1 = xyz[w, 1] - c1
        d2 = xyz[w, 2] - c2
        nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        side = 0.0
        if nn > 0.0:
            side = (n0 * d0 + n1 * d1 + n2 * d2) / nn
            g = -1.0 / nn if side > 0.0 else 1.0 / nn
            n0 *= g
            n1 *= g
            n2 *= g
            side = abs(side)
        else:
            n0 = 0.0
            n1 = 0.0
            n2 = 0.0
        cen[0] += c0
        cen[1] += c1
        cen[2] += c2
        # w mirrored: its offset along the normal changes side (n points away from w)
        refl[0] += xyz[w, 0] + 2.0 * side * n0
        refl[1] += xyz[w, 1] + 2.0 * side * n1
        refl[2] += xyz[w, 2] + 2.0 * side * n2
        far[0] += side * n0
        far[1] += side * n1
        far[2] += side * n2
        normal[0] += n0
        normal[1] += n1
        normal[2] += n2
    nn = math.sqrt(normal[0] ** 2 + normal[1] ** 2 + normal[2] ** 2)
    for ax in range(3):
        cen[ax] /= m
        refl[ax] /= m
        far[ax] /= m
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


# Backward-adaptive state, the same on both sides (learnt from decoded vertices only).
# The apex prediction is ``cen + h1 L normal + h2 far``: (h1, h2) solve the least-squares
# normal equations of the vertices so far (st[0:3] the Gram matrix, st[3:5] the right-hand
# side, over L^2 so that they are unitless, slowly forgetting). st[5:17] the mean |residual|
# / L per coded axis in four buckets: vertices seeing 1, 2 or more faces, and border
# vertices predicted on their border plane; st[17], st[18] the running costs of the apex
# and the reflection predictors.
H1, H2 = 0.6, 0.0  # starting heights (the bench meshes' means), worth PRIOR vertices
PRIOR = 4.0
FORGET = 1.0 / 1024.0
A_RATE = 1.0 / 512.0  # the mean sizes move slowly: the bit-length models do the rest
COST_RATE = 1.0 / 16.0
# starting mean |residual| / L per bucket (in-plane, in-plane, normal): the bench
# meshes' typical values
A_START = (
    (0.25, 0.25, 0.2),
    (0.19, 0.19, 0.15),
    (0.11, 0.11, 0.13),
    (0.07, 0.07, 0.2),
    (0.08, 0.08, 0.01),
    (0.02, 0.02, 0.2),
)
N_STATE = 29  # the last: the number of vertices
N_SETS = 12  # model sets: class (in-plane, normal, no face, border normal, flat, crease) x half bit
CREASE_SAME, CREASE_APART = 0.995, 0.9
COST_APEX, COST_REFL, COST_BAPEX, COST_PAR, COST_MID = 23, 24, 25, 26, 27
FLAT = 0.01


@kernel
def _new_state(nv):
    st = np.zeros(N_STATE)
    st[N_STATE - 1] = nv
    st[0] = PRIOR
    st[2] = PRIOR
    st[3] = PRIOR * H1
    st[4] = PRIOR * H2
    for b in range(6):
        for ax in range(3):
            st[5 + 3 * b + ax] = A_START[b][ax]
    return st


@kernel
def _heights(st):
    """(h1, h2) from the normal equations (the starting heights if they are singular)."""
    det = st[0] * st[2] - st[1] * st[1]
    if not det > 1e-12 * (st[0] * st[2]):
        return H1, H2
    return (st[3] * st[2] - st[4] * st[1]) / det, (st[0] * st[4] - st[1] * st[3]) / det


@kernel
def _apex(st, ln, cen, far, normal, pred):
    h1, h2 = _heights(st)
    for ax in range(3):
        pred[ax] = cen[ax] + h1 * ln * normal[ax] + h2 * far[ax]


@kernel
def _choose(st, ln, xyz, k, cen, refl, far, normal, pred):
    """The prediction of vertex k: the apex over the faces' centre at the learnt heights,
    or the mean reflection when that has been cheaper lately; the previous vertex when
    k sees no face."""
    if ln < 0.0:
        for ax in range(3):
            pred[ax] = xyz[k - 1, ax] if k > 0 else 0.0
    elif st[COST_REFL] < st[COST_APEX]:
        for ax in range(3):
            pred[ax] = refl[ax]
    else:
        _apex(st, ln, cen, far, normal, pred)


@kernel(inline=True)
def _bits(x):
    """Bit length of the non-negative float ``x`` truncated to an integer."""
    t = np.int64(x) if x < 1e18 else np.int64(1) << 60
    return 64 - np.int64(leading_zeros(np.uint64(t)))


@kernel(inline=True)
def _miss_bits(xyz, k, ax, guess, ln):
    """Bits by which ``guess`` misses vertex ``k`` along ``ax``, in 1/256 of the length ``ln``."""
    return _bits(abs(xyz[k, ax] - guess) * 256.0 / ln)


@kernel(inline=True)
def _misses(xyz, k, guess, ln):
    """:func:`_miss_bits` summed over the three axes."""
    c = 0
    for ax in range(3):
        c += _miss_bits(xyz, k, ax, guess[ax], ln)
    return c


@kernel(inline=True)
def _track(st, i, bits):
    """Move the running cost ``st[i]`` of one prediction towards ``bits``."""
    st[i] += (bits - st[i]) * COST_RATE


@kernel
def _learn(st, ln, bucket, xyz, k, cen, refl, far, normal, pred, err):
    """Update the adaptive state from decoded vertex k and its residual ``err`` per coded
    axis (in the face frame when quantized). ``pred`` is scratch space."""
    if ln <= 0.0:
        return
    b = 5 + 3 * bucket
    for ax in range(3):
        st[b + ax] += (min(abs(err[ax]) / ln, 4.0) - st[b + ax]) * A_RATE
    _apex(st, ln, cen, far, normal, pred)
    _track(st, COST_APEX, _misses(xyz, k, pred, ln))
    _track(st, COST_REFL, _misses(xyz, k, refl, ln))
    g11 = 0.0
    g12 = 0.0
    g22 = 0.0
    y1 = 0.0
    y2 = 0.0
    for ax in range(3):
        f1 = normal[ax]
        f2 = far[ax] / ln
        y = (xyz[k, ax] - cen[ax]) / ln
        g11 += f1 * f1
        g12 += f1 * f2
        g22 += f2 * f2
        y1 += f1 * y
        y2 += f2 * y
    if g11 > 0.0:  # a vertex whose faces' normals cancel out teaches no heights
        keep = 1.0 - FORGET
        st[0] = st[0] * keep + g11
        st[1] = st[1] * keep + g12
        st[2] = st[2] * keep + g22
        st[3] = st[3] * keep + y1
        st[4] = st[4] * keep + y2


@kernel
def _learn_border(st, ln, xyz, k, apex, par):
    """Update the running costs of the border predictions (apex and parallelogram)."""
    _track(st, COST_BAPEX, _misses(xyz, k, apex, ln))
    _track(st, COST_PAR, _misses(xyz, k, par, ln))
    cm = 0
    for ax in range(3):
        cm += _miss_bits(xyz, k, ax, 0.5 * (apex[ax] + par[ax]), ln)
    _track(st, COST_MID, cm)


@kernel
def _estimate(s):
    """For a residual of mean size ``s``: the half bit (1 when ``s`` lies in the upper
    half of its octave, ``s >= 1.5 * 2**(q-1)``) and the estimate ``q``, the bit length
    of ``floor(s)``; both from ``t = floor(16 s)``. No libm, so both sides agree on
    every machine."""
    t = np.int64(s * 16.0) if s < 1e15 else np.int64(1) << 54
    n = 64 - np.int64(leading_zeros(np.uint64(t)))
    if n < 2:
        return 0, 0
    return (t >> (n - 2)) & 1, n - 4


@kernel
def _scale(st, mode, ax, ln, bucket, p, bits, f64, i64, f32, i32):
    """Model set and bit length estimate for coded axis ``ax``."""
    if ln < 0.0:  # no face: the first vertex from nothing, others from the one before
        if mode != 0:
            return 4, 0
        if bucket == 0:
            return 4, bits
        return 4, bits - _bits(st[N_STATE - 1]) // 3  # about the spacing of nv points
    s = st[5 + 3 * bucket + ax] * ln
    if mode != 0:  # in units of the ordered bit patterns around the prediction
        d = _to_int(p + s, mode, bits, f64, i64, f32, i32) - _to_int(
            p, mode, bits, f64, i64, f32, i32
        )
        s = float(abs(d))
    frac, q = _estimate(s)
    if bucket == 5:  # a crease: the line is z, the planes' normals x and y
        cls = 5 if ax == 2 else 4
    else:
        cls = bucket if bucket >= 3 and ax == 2 else _CLASS[ax]
    return 2 * cls + frac, q


@kernel
def _vertex_model(st, xyz, k, ptr, quads, bptr, bidx, btri, vnorm, mark, mark2, w, pred):
    """Predict vertex k into ``pred``; ``w`` rows are scratch: 0 the faces' centre, 1 the
    reflection, 2 the far term, 3 the faces' normal, 4 the frame's z axis (the border
    plane's normal for a border vertex, else the faces' normal), 5 and 6 the plane.
    Return ``(L, bucket)``: the face size (-1 with no face) and the scale bucket."""
    ln = _predict(xyz, k, ptr, quads, w[0], w[1], w[2], w[3])
    _choose(st, ln, xyz, k, w[0], w[1], w[2], w[3], pred)
    for ax in range(3):
        w[4, ax] = w[3, ax]
    if ln < 0.0:
        return ln, min(k, 1)
    w[9, 0] = 0.0
    if _surface(xyz, k, bptr, bidx, btri, vnorm, mark, w[5], w[6]) > 0:
        _project(pred, w[5], w[6])
        for ax in range(3):
            w[4, ax] = w[6, ax]
            w[7, ax] = pred[ax]
        npar = _parallelogram(xyz, k, bptr, bidx, btri, w[8])
        if npar > 0:
            w[9, 0] = 1.0
            _project(w[8], w[5], w[6])
            best = min(st[COST_BAPEX], st[COST_PAR], st[COST_MID])
            if st[COST_PAR] == best:
                for ax in range(3):
                    pred[ax] = w[8, ax]
            elif st[COST_MID] == best:
                for ax in range(3):
                    pred[ax] = 0.5 * (w[7, ax] + w[8, ax])
        if _flatness(xyz, k, bptr, bidx, btri, mark, w[5], w[6]) <= FLAT * ln:
            return ln, 4
        if _crease(xyz, k, bptr, bidx, btri, vnorm, mark, mark2, ln, pred, w[4]):
            return ln, 5
        return ln, 3
    return ln, min(ptr[k + 1] - ptr[k], 3) - 1


@kernel(inline=True)  # numba IR inlining: the kernels compile as if written out
def _coder_state(nv):
    """What encoder and decoder start from alike: the adaptive models, the predictor's
    state and scratch, and the float/int views that ``_to_int`` and ``_scale`` reinterpret
    bits through."""
    models = np.full(N_SETS * pk.SCALED_SET, pk.STATE_INIT, dtype=np.uint16)
    st = _new_state(nv)
    w = np.zeros((10, 3))
    vnorm = np.zeros((nv, 3))
    mark = np.full(nv, -1, dtype=np.int64)
    mark2 = np.full(nv, -1, dtype=np.int64)
    pred = np.empty(3)
    res = np.empty(3, dtype=np.int64)
    err = np.empty(3)
    f64 = np.empty(1, dtype=np.float64)
    f32 = np.empty(1, dtype=np.float32)
    return (
        models,
        st,
        w,
        vnorm,
        mark,
        mark2,
        pred,
        res,
        err,
        f64,
        f64.view(np.int64),
        f32,
        f32.view(np.int32),
    )


@kernel
def _encode_kernel(vals, xyz, ptr, quads, bptr, bidx, btri, mode, bits, out):
    nv = vals.shape[0]
    models, st, w, vnorm, mark, mark2, pred, res, err, f64, i64, f32, i32 = _coder_state(nv)
    cs = pk.start_encoder(out)
    cap = out.size
    for k in range(nv):
        if cs[2] + 3 * pk.SCALED_MAX_BYTES + 16 > cap:
            return -1
        ln, bucket = _vertex_model(
            st, xyz, k, ptr, quads, bptr, bidx, btri, vnorm, mark, mark2, w, pred
        )
        for ax in range(3):
            res[ax] = vals[k, ax] - _to_int(pred[ax], mode, bits, f64, i64, f32, i32)
        if mode == 0:  # into the frame of the plane: z along its normal (seed-004 §10.9 step 4)
            a1, a2 = _lift_angles(w[4])
            _rotate(res, 0, 1, a1, False)
            _rotate(res, 0, 2, a2, False)
        for ax in range(3):
            s, q = _scale(st, mode, ax, ln, bucket, pred[ax], bits, f64, i64, f32, i32)
            pk.put_scaled(cs, out, models, s * pk.SCALED_SET, q, res[ax])
            err[ax] = float(res[ax]) if mode == 0 else xyz[k, ax] - pred[ax]
        _learn(st, ln, bucket, xyz, k, w[0], w[1], w[2], w[3], pred, err)
        if w[9, 0] > 0.0:
            _learn_border(st, ln, xyz, k, w[7], w[8])
        _add_border_normals(xyz, k, bptr, bidx, btri, vnorm)
    if cs[2] + 8 > cap:
        return -1
    return pk.finish_encoder(cs, out)


@kernel
def _decode_kernel(data, ptr, quads, bptr, bidx, btri, mode, bits, vals, xyz):
    """Return 0, or 1 when the stream ran short, 2 on an impossible value."""
    nv = vals.shape[0]
    models, st, w, vnorm, mark, mark2, pred, res, err, f64, i64, f32, i32 = _coder_state(nv)
    cs = pk.start_decoder(data)
    hi = np.int64((1 << bits) - 1) if mode == 0 else np.int64(0)
    nmax = bits + 2 if mode == 0 else 64  # rotated: up to sqrt(3) longer, and a sign
    for k in range(nv):
        if cs[2] > data.size + 4:
            return 1
        ln, bucket = _vertex_model(
            st, xyz, k, ptr, quads, bptr, bidx, btri, vnorm, mark, mark2, w, pred
        )
        for ax in range(3):
            s, q = _scale(st, mode, ax, ln, bucket, pred[ax], bits, f64, i64, f32, i32)
            r, ok = pk.get_scaled(cs, data, models, s * pk.SCALED_SET, q, nmax)
            if not ok:
                return 2
            res[ax] = r
            err[ax] = float(r)
        if mode == 0:
            a1, a2 = _lift_angles(w[4])
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
            if mode != 0:
                err[ax] = xyz[k, ax] - pred[ax]
        _learn(st, ln, bucket, xyz, k, w[0], w[1], w[2], w[3], pred, err)
        if w[9, 0] > 0.0:
            _learn_border(st, ln, xyz, k, w[7], w[8])
        _add_border_normals(xyz, k, bptr, bidx, btri, vnorm)
    return pk.end_status(data, cs[0], cs[2])  # ends where the encoder's bytes end
