"""Pre-integration tables for linear ray segments (Engel/Kraus/Ertl; exact linear model).

Model and convention
--------------------
A ray segment is ``length`` voxels long and its scalar goes linearly from table index
``i`` (front, nearer the eye) to table index ``j`` (back). The transfer-function table
``tf[k] = (r, g, b, a)`` (e.g. :meth:`volpack.render.transfer.TransferFunction.table`)
is read as

* extinction per voxel length ``tau_k = -ln(1 - a_k)`` (``a`` is the opacity of one
  voxel; ``a = 1`` becomes :data:`TAU_MAX`),
* emission ``c(s) * tau(s)`` with non-associated colour ``c``: the usual
  "colour weighted by extinction" model, Engel's eq. (7),

with ``tau`` and ``c`` linear in the scalar between table entries. The table entry
``(i, j)`` holds the premultiplied (associated) colour ``C`` and the opacity ``A`` of
the whole segment::

    A = 1 - exp(-int_0^L tau(s(x)) dx)
    C = int_0^L c(s(x)) tau(s(x)) exp(-int_0^x tau(s(x')) dx') dx

and is composited front to back as ``C_acc += (1 - A_acc) C; A_acc += (1 - A_acc) A``.
On the diagonal (constant scalar) ``A = 1 - (1 - a)^L`` and ``C = c A`` exactly, with
both methods. ``A`` is symmetric in ``(i, j)``; ``C`` is not (the nearer colour wins).

Methods
-------
``fast``
    The integral-function method (digest 2.2c), O(n^2). With the prefix integrals
    ``T(s) = int tau`` and ``K(s) = int c tau`` (exact for the linear pieces),
    ``A = 1 - exp(-L (T(j) - T(i)) / (j - i))`` (eq. 8) and
    ``C = A * (K(j) - K(i)) / (T(j) - T(i))``: the extinction-weighted mean colour of
    the segment times its opacity. Self-attenuation *inside* the segment is neglected
    for the colour, as in Engel's eq. (10), whose ``C = L (K(j) - K(i)) / (j - i)``
    equals ours to first order in the optical depth; ours is in addition exact on the
    diagonal and whenever the colour is constant along the segment, and never exceeds
    ``A`` (eq. 10 grows without bound as the optical depth grows). Symmetric in (i, j).
``exact``
    With self-attenuation inside the segment (digest 3.9), O(n^2 k). Each TF cell
    ``[k, k+1]`` crossed with ``delta = L / |j - i|`` voxels per index unit contributes,
    by parts, ``E = c_in * J + c_out * (alpha - J)`` where ``alpha`` is the cell's
    opacity and ``J = int_0^1 (1 - exp(-Phi(u))) du`` with the quadratic optical depth
    ``Phi``; ``J`` is the only numerical integral (composite 3-point Gauss-Legendre,
    one sub-interval per unit of ``delta * tau``, at most 256). The cells of one segment
    are composited with the associative "over" operator; all segments of one length
    ``|j - i| = m`` are sliding windows of ``m`` cells, evaluated in O(n) per ``m`` by
    block prefix/suffix composites, so nothing is ever divided by a transmittance and
    no ``exp(+x)`` is formed. Opacity comes from the prefix integral of ``tau``, as in
    ``fast`` (it is exact there).
``engel``
    Eq. (10) verbatim, ``C = L (K(j) - K(i)) / (j - i)`` and ``C = c tau L`` on the
    diagonal, for comparison only: it can exceed ``A`` and 1.

Isosurfaces
-----------
:func:`iso_table` gives, for each (front, back) pair, the first isosurface crossed from
the front (half-open: a hit needs ``s_f < s_iso <= s_b`` or ``s_b <= s_iso < s_f``, so
an iso lying exactly on a sample is counted once, digest 5.4) as premultiplied
``(r a, g a, b a, a)``, zero where none is crossed. :func:`iso_hits` gives the index of
the iso hit and the interpolation weight of the back sample for shading.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel
from ..errors import FormatError

__all__ = ["TAU_MAX", "iso_hits", "iso_table", "opacity_correct", "preintegrate"]

#: Extinction per voxel used for ``a = 1`` (and the largest one used): transmittance
#: ``exp(-40) = 4e-18`` per voxel, opaque in any float32 sense.
TAU_MAX = 40.0

_METHODS = {"fast": 0, "exact": 1, "engel": 2}


def preintegrate(tf_table, length: float, method: str = "fast") -> np.ndarray:
    """Pre-integrated colour and opacity of every linear segment between table entries.

    Parameters
    ----------
    tf_table : array_like, shape (n, 4)
        Non-associated ``(r, g, b, a)`` per table entry, all in [0, 1]; ``a`` is the
        opacity of a one-voxel slab.
    length : float
        Segment length in voxels (>= 0); 0 gives an all-zero table.
    method : {"fast", "exact", "engel"}
        See the module docstring.

    Returns
    -------
    ndarray, shape (n, n, 4), float32
        ``out[i, j] = (C_r, C_g, C_b, A)`` for front index ``i`` and back index ``j``,
        with premultiplied colour ``0 <= C <= A <= 1`` (``engel`` excepted).
    """
    tab = _check_table(tf_table)
    try:
        length = float(length)
    except (TypeError, ValueError) as e:
        raise FormatError(f"segment length: expected a number, found {length!r}") from e
    if not math.isfinite(length) or length < 0:
        raise FormatError(f"segment length: expected a finite number >= 0, found {length}")
    if method not in _METHODS:
        raise FormatError(
            f"pre-integration method: expected one of {list(_METHODS)}, found {method!r}"
        )
    tau = _extinction(tab[:, 3])
    col = np.ascontiguousarray(tab[:, :3])
    n = len(tab)
    out = np.empty((n, n, 4), dtype=np.float32)
    if method == "exact":
        _preint_exact_kernel(tau, col, length, out)
    else:
        _preint_fast_kernel(tau, col, length, method == "engel", out)
    return out


def opacity_correct(alpha, ratio):
    """Opacity of a slab ``ratio`` times as thick: ``1 - (1 - alpha) ** ratio``.

    Works on scalars and arrays (float arrays keep their dtype); ``alpha`` in [0, 1],
    ``ratio >= 0``. Accurate for tiny ``alpha`` (``-expm1(ratio * log1p(-alpha))``).
    """
    a = np.asarray(alpha)
    r = np.asarray(ratio, dtype=np.float64)
    a64 = a.astype(np.float64)
    if not (np.all(np.isfinite(a64)) and np.all((a64 >= 0) & (a64 <= 1))):
        raise FormatError("opacity_correct: expected alpha in [0, 1], found values outside")
    if not (np.all(np.isfinite(r)) and np.all(r >= 0)):
        raise FormatError("opacity_correct: expected a finite ratio >= 0, found otherwise")
    opaque = a64 >= 1.0
    log_t = np.log1p(-np.where(opaque, 0.0, a64))
    out = np.where(opaque, np.where(r > 0, 1.0, 0.0), -np.expm1(r * log_t))
    if np.ndim(out) == 0:
        return float(out)
    if a.dtype.kind == "f":
        return out.astype(a.dtype)
    return out


def iso_table(n: int, lo: float, hi: float, isos) -> np.ndarray:
    """Isosurface pre-integration table: the first iso crossed by each segment.

    Parameters
    ----------
    n : int
        Table size; entry ``k`` stands for the value ``lo + k (hi - lo) / (n - 1)``.
    lo, hi : float
        Data range of the table.
    isos : list of (value, (r, g, b), opacity)
        Isosurfaces in data units, any order; colour and opacity in [0, 1].

    Returns
    -------
    ndarray, shape (n, n, 4), float32
        ``out[f, b]`` is the premultiplied ``(r a, g a, b a, a)`` of the first iso met
        going from the front value ``f`` to the back value ``b`` (half-open interval,
        see the module docstring), zero when none is crossed. The renderer shades it.
    """
    hit, _, vals, rgba = _iso_prepare(n, lo, hi, isos)
    out = np.zeros((len(vals), len(vals), 4), dtype=np.float32)
    mask = hit >= 0
    prem = rgba.copy()
    prem[:, :3] *= prem[:, 3:4]
    out[mask] = prem[hit[mask]]
    return out


def iso_hits(n: int, lo: float, hi: float, isos) -> tuple[np.ndarray, np.ndarray]:
    """Which iso each segment hits and where, for shading (same arguments as :func:`iso_table`).

    Returns ``(index, weight)``, both ``(n, n)``: ``index[f, b]`` is the position of the
    hit iso in ``isos`` sorted by value (-1 for none) and ``weight[f, b]`` is the weight
    of the back sample at the hit, ``(s_iso - s_f) / (s_b - s_f)`` (0 for none).
    """
    hit, ip, _, _ = _iso_prepare(n, lo, hi, isos)
    return hit, ip


# -- helpers ---------------------------------------------------------------------------


def _check_table(tf_table) -> np.ndarray:
    try:
        tab = np.asarray(tf_table, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise FormatError(f"transfer-function table: expected numbers, found {e}") from e
    if tab.ndim != 2 or tab.shape[1] != 4 or tab.shape[0] < 1:
        raise FormatError(f"transfer-function table: expected shape (n >= 1, 4), found {tab.shape}")
    if not np.all(np.isfinite(tab)) or tab.min() < 0 or tab.max() > 1:
        raise FormatError(
            "transfer-function table: expected finite RGBA in [0, 1], found otherwise"
        )
    return tab


def _extinction(a: np.ndarray) -> np.ndarray:
    """Extinction per voxel ``-ln(1 - a)``, capped at :data:`TAU_MAX` (``a = 1`` included)."""
    a = np.asarray(a, dtype=np.float64)
    tau = np.full(a.shape, TAU_MAX)
    ok = a < 1.0
    tau[ok] = np.minimum(-np.log1p(-a[ok]), TAU_MAX)
    return tau


def _iso_prepare(n, lo, hi, isos):
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise FormatError(f"iso table size: expected an integer >= 1, found {n!r}")
    try:
        lo, hi = float(lo), float(hi)
    except (TypeError, ValueError) as e:
        raise FormatError(f"iso table range: expected numbers, found {lo!r}, {hi!r}") from e
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi < lo:
        raise FormatError(f"iso table range: expected finite lo <= hi, found [{lo}, {hi}]")
    rows = []
    for k, iso in enumerate(isos):
        try:
            value, rgb, alpha = iso
            row = (float(value), *(float(c) for c in rgb), float(alpha))
        except (TypeError, ValueError) as e:
            raise FormatError(
                f"isosurface {k}: expected (value, (r, g, b), opacity), found {iso!r}"
            ) from e
        if len(row) != 5 or not all(math.isfinite(v) for v in row):
            raise FormatError(
                f"isosurface {k}: expected finite (value, (r, g, b), opacity), found {iso!r}"
            )
        if not all(0.0 <= v <= 1.0 for v in row[1:]):
            raise FormatError(
                f"isosurface {k}: expected colour and opacity in [0, 1], found {row[1:]}"
            )
        rows.append(row)
    rows.sort(key=lambda r: r[0])
    arr = np.array(rows, dtype=np.float64).reshape(-1, 5)
    vals = np.linspace(lo, hi, int(n)) if n > 1 else np.array([lo])
    hit = np.empty((len(vals), len(vals)), dtype=np.int64)
    ip = np.empty((len(vals), len(vals)), dtype=np.float32)
    _iso_hits_kernel(vals, np.ascontiguousarray(arr[:, 0]), hit, ip)
    return hit, ip, vals, arr[:, 1:].astype(np.float32)


# -- kernels ---------------------------------------------------------------------------


@kernel
def _preint_fast_kernel(tau, col, length, engel, out):
    """Integral-function tables (see ``fast`` / ``engel`` in the module docstring)."""
    n = tau.shape[0]
    tp = np.zeros(n)  # prefix integral of tau over index units
    kp = np.zeros((n, 3))  # prefix integral of c * tau (exact for linear c and tau)
    for k in range(n - 1):
        t0 = tau[k]
        t1 = tau[k + 1]
        tp[k + 1] = tp[k] + 0.5 * (t0 + t1)
        for ch in range(3):
            c0 = col[k, ch]
            c1 = col[k + 1, ch]
            kp[k + 1, ch] = kp[k, ch] + (2.0 * c0 * t0 + c0 * t1 + c1 * t0 + 2.0 * c1 * t1) / 6.0
    for i in range(n):
        for j in range(n):
            if i == j:
                a = -math.expm1(-tau[i] * length)
                out[i, j, 3] = a
                for ch in range(3):
                    if engel:
                        out[i, j, ch] = col[i, ch] * tau[i] * length
                    else:
                        out[i, j, ch] = col[i, ch] * a
                continue
            m = abs(j - i)
            dt = abs(tp[j] - tp[i])
            a = -math.expm1(-length * dt / m)
            out[i, j, 3] = a
            for ch in range(3):
                dk = abs(kp[j, ch] - kp[i, ch])
                if engel:
                    out[i, j, ch] = length * dk / m
                elif dt > 0.0:
                    r = dk / dt
                    if r > 1.0:
                        r = 1.0
                    out[i, j, ch] = a * r
                else:
                    out[i, j, ch] = 0.0


@kernel
def _cell_integral_kernel(t_in, t_out, delta):
    """Opacity ``alpha`` and ``J = int_0^1 1 - exp(-Phi(u)) du`` of one TF cell.

    The cell is crossed over ``delta`` voxels with extinction going linearly from
    ``t_in`` to ``t_out``: ``Phi(u) = delta (t_in u + (t_out - t_in) u^2 / 2)``.
    Composite 3-point Gauss-Legendre, one sub-interval per unit of the largest
    ``delta * tau`` (at most 256). ``0 <= J <= alpha`` is enforced.
    """
    phi1 = delta * 0.5 * (t_in + t_out)
    alpha = -math.expm1(-phi1)
    g = delta * max(t_in, t_out)
    nsub = int(math.ceil(g))
    if nsub < 1:
        nsub = 1
    if nsub > 256:
        nsub = 256
    h = 1.0 / nsub
    x0 = 0.5 - 0.5 * math.sqrt(0.6)
    x2 = 0.5 + 0.5 * math.sqrt(0.6)
    half_slope = 0.5 * (t_out - t_in)
    acc = 0.0
    for k in range(nsub):
        u = (k + x0) * h
        acc += (5.0 / 18.0) * -math.expm1(-delta * u * (t_in + half_slope * u))
        u = (k + 0.5) * h
        acc += (8.0 / 18.0) * -math.expm1(-delta * u * (t_in + half_slope * u))
        u = (k + x2) * h
        acc += (5.0 / 18.0) * -math.expm1(-delta * u * (t_in + half_slope * u))
    j = acc * h
    if j < 0.0:
        j = 0.0
    if j > alpha:
        j = alpha
    return alpha, j


@kernel
def _window_over_kernel(ec, et, m, pre_c, pre_t, suf_c, suf_t, res):
    """Composite every window of ``m`` consecutive cells front to back ("over").

    ``ec[k]`` is the premultiplied colour and ``et[k]`` the transmittance of cell ``k``
    in ray order. ``res[f]`` receives the colour of cells ``f .. f+m-1``. Blocks of
    ``m`` cells get prefix and suffix composites; a window is one suffix over one
    prefix, so the whole pass is O(cells) and never divides.
    """
    nc = et.shape[0]
    for k in range(nc):
        if k % m == 0:
            pre_t[k] = et[k]
            for ch in range(3):
                pre_c[k, ch] = ec[k, ch]
        else:
            pre_t[k] = pre_t[k - 1] * et[k]
            for ch in range(3):
                pre_c[k, ch] = pre_c[k - 1, ch] + pre_t[k - 1] * ec[k, ch]
    for k in range(nc - 1, -1, -1):
        if k % m == m - 1 or k == nc - 1:
            suf_t[k] = et[k]
            for ch in range(3):
                suf_c[k, ch] = ec[k, ch]
        else:
            suf_t[k] = et[k] * suf_t[k + 1]
            for ch in range(3):
                suf_c[k, ch] = ec[k, ch] + et[k] * suf_c[k + 1, ch]
    for f in range(nc - m + 1):
        e = f + m - 1
        if f % m == 0:
            for ch in range(3):
                res[f, ch] = pre_c[e, ch]
        else:
            for ch in range(3):
                res[f, ch] = suf_c[f, ch] + suf_t[f] * pre_c[e, ch]


@kernel
def _preint_exact_kernel(tau, col, length, out):
    """Exact tables with self-attenuation (see ``exact`` in the module docstring)."""
    n = tau.shape[0]
    tp = np.zeros(n)
    for k in range(n - 1):
        tp[k + 1] = tp[k] + 0.5 * (tau[k] + tau[k + 1])
    for i in range(n):
        a = -math.expm1(-tau[i] * length)
        out[i, i, 3] = a
        for ch in range(3):
            out[i, i, ch] = col[i, ch] * a
    nc = n - 1
    if nc < 1:
        return
    up_c = np.empty((nc, 3))
    up_t = np.empty(nc)
    dn_c = np.empty((nc, 3))  # in ray order for downward rays: entry r is cell nc-1-r
    dn_t = np.empty(nc)
    pre_c = np.empty((nc, 3))
    pre_t = np.empty(nc)
    suf_c = np.empty((nc, 3))
    suf_t = np.empty(nc)
    res_up = np.empty((nc, 3))
    res_dn = np.empty((nc, 3))
    for m in range(1, n):
        delta = length / m
        for k in range(nc):
            t = math.exp(-delta * 0.5 * (tau[k] + tau[k + 1]))
            # upward: enter at k, leave at k + 1
            alpha, jw = _cell_integral_kernel(tau[k], tau[k + 1], delta)
            up_t[k] = t
            for ch in range(3):
                up_c[k, ch] = col[k, ch] * jw + col[k + 1, ch] * (alpha - jw)
            # downward: enter at k + 1, leave at k
            alpha, jw = _cell_integral_kernel(tau[k + 1], tau[k], delta)
            r = nc - 1 - k
            dn_t[r] = t
            for ch in range(3):
                dn_c[r, ch] = col[k + 1, ch] * jw + col[k, ch] * (alpha - jw)
        _window_over_kernel(up_c, up_t, m, pre_c, pre_t, suf_c, suf_t, res_up)
        _window_over_kernel(dn_c, dn_t, m, pre_c, pre_t, suf_c, suf_t, res_dn)
        for f in range(n - m):
            # upward segment f -> f + m covers cells f .. f + m - 1
            b = f + m
            a = -math.expm1(-length * (tp[b] - tp[f]) / m)
            out[f, b, 3] = a
            out[b, f, 3] = a
            # downward segment b -> f covers, in ray order, reversed cells nc - b ..
            r = nc - b
            for ch in range(3):
                c = res_up[f, ch]
                out[f, b, ch] = min(max(c, 0.0), a)
                c = res_dn[r, ch]
                out[b, f, ch] = min(max(c, 0.0), a)


@kernel
def _iso_hits_kernel(vals, isov, hit, ip):
    """First iso crossed from front value ``vals[f]`` to back value ``vals[b]``.

    ``isov`` is sorted ascending. Rising segments hit the smallest iso in
    ``(s_f, s_b]``, falling ones the largest in ``[s_b, s_f)``.
    """
    n = vals.shape[0]
    niso = isov.shape[0]
    for f in range(n):
        sf = vals[f]
        for b in range(n):
            sb = vals[b]
            k = -1
            if sb > sf:
                for q in range(niso):
                    if isov[q] > sf:
                        if isov[q] <= sb:
                            k = q
                        break
            elif sb < sf:
                for q in range(niso - 1, -1, -1):
                    if isov[q] < sf:
                        if isov[q] >= sb:
                            k = q
                        break
            hit[f, b] = k
            if k >= 0:
                ip[f, b] = (isov[k] - sf) / (sb - sf)
            else:
                ip[f, b] = 0.0
