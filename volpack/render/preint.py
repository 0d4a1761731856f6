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

Pre-integrated lighting
-----------------------
Shading inside a segment (seed 004 eq. 1.33, after Meissner et al.; seed 000 5.2): the
diffuse factor ``l = n.l`` is taken linear along the segment, from ``l_f`` at the front
sample to ``l_b`` at the back one, so the shaded colour is
``ka C + kd (l_f (C - B) + l_b B)`` with one more table,

    B = int_0^L w(x) c(s(x)) tau(s(x)) exp(-int_0^x tau) dx,   w = x / L,

the colour weighted by the position along the segment (``C - B`` is the front-weighted
part). ``B / C`` is the emission centroid ``w*``, which also places the one
representative normal ``(1 - w*) n_f + w* n_b`` of the specular term (eq. 1.34). Both
methods build ``B`` beside ``C``: ``fast`` from a first-moment prefix integral (again
without self-attenuation in the colour, and equal to ``C / 2`` on the diagonal and for
constant ``c tau``), ``exact`` with the attenuation, by extending the window composite
with a position moment (see :func:`_window_over_kernel`).

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
from .transfer import check_range

__all__ = ["TAU_MAX", "TableUpdater", "iso_hits", "iso_table", "opacity_correct", "preintegrate"]

#: Extinction per voxel used for ``a = 1`` (and the largest one used): transmittance
#: ``exp(-40) = 4e-18`` per voxel, opaque in any float32 sense.
TAU_MAX = 40.0

_METHODS = {"fast": 0, "exact": 1, "engel": 2}


def preintegrate(
    tf_table, length: float, method: str = "fast", *, lighting: bool = False
) -> np.ndarray:
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
    lighting : bool
        Also return the back-weighted colour ``B`` (module docstring, "Pre-integrated
        lighting") in channels 4-6.

    Returns
    -------
    ndarray, shape (n, n, 4) or (n, n, 7) with ``lighting``, float32
        ``out[i, j] = (C_r, C_g, C_b, A[, B_r, B_g, B_b])`` for front index ``i`` and
        back index ``j``, with premultiplied colour ``0 <= B <= C <= A <= 1`` (``engel``
        excepted).
    """
    tab = _check_table(tf_table)
    length = _check_length(length)
    if method not in _METHODS:
        raise FormatError(
            f"pre-integration method: expected one of {list(_METHODS)}, found {method!r}"
        )
    tau = extinction(tab[:, 3])
    col = np.ascontiguousarray(tab[:, :3])
    n = len(tab)
    out = np.empty((n, n, 7 if lighting else 4), dtype=np.float32)
    if method == "exact":
        _preint_exact_kernel(tau, col, length, out)
    else:
        _preint_fast_kernel(tau, col, length, method == "engel", out, 0, n - 1)
    return out


class TableUpdater:
    """A pre-integration table kept current while the transfer function is edited.

    After a change, only the entries whose segment crosses a changed TF entry are
    recomputed (seed 001's local update): with ``fast`` from the new prefix integrals,
    with ``exact`` from a cache of every cell's integrals at every segment length, in
    which only the changed cells are integrated again. The cache holds
    ``14 (n - 1)^2`` float64 (7 MB for n = 256). The table equals a fresh
    :func:`preintegrate` of the same TF.

    >>> up = TableUpdater(tf, 1.0, "exact")   # full build
    >>> n_entries = up.update(edited_tf)       # local update; ``up.table`` is current
    """

    def __init__(self, tf_table, length: float, method: str = "exact", *, lighting=False):
        if method not in ("fast", "exact"):
            raise FormatError(f"table update method: expected 'fast' or 'exact', found {method!r}")
        tab = _check_table(tf_table)
        self.length = _check_length(length)
        self.method = method
        self.lighting = bool(lighting)
        n = len(tab)
        self.table = np.empty((n, n, 7 if lighting else 4), dtype=np.float32)
        if method == "exact":
            nc = max(n - 1, 0)
            self._c = np.zeros((max(n - 1, 1), 2, nc, 3))
            self._f = np.zeros((max(n - 1, 1), 2, nc, 3))
            self._t = np.zeros((max(n - 1, 1), 2, nc))
        self._tab = np.full_like(tab, np.nan)  # forces a full build
        self.update(tab)

    def update(self, tf_table) -> int:
        """Bring the table up to ``tf_table`` (same size); return the entries recomputed."""
        tab = _check_table(tf_table)
        n = len(self._tab)
        if tab.shape != self._tab.shape:
            raise FormatError(
                f"table update: expected a TF of shape {self._tab.shape}, found {tab.shape}"
            )
        changed = np.flatnonzero(np.any(tab != self._tab, axis=1))
        if changed.size == 0:
            return 0
        k0, k1 = int(changed[0]), int(changed[-1])
        tau = extinction(tab[:, 3])
        col = np.ascontiguousarray(tab[:, :3])
        if self.method == "exact":
            _exact_update_kernel(
                tau, col, self.length, k0, k1, self._c, self._f, self._t, self.table
            )
        else:
            _preint_fast_kernel(tau, col, self.length, False, self.table, k0, k1)
        self._tab = tab
        # entries (i, j) with the segment [min, max] meeting [k0, k1]
        below, above = k0, n - 1 - k1
        return n * n - below * below - above * above


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


def _check_length(length) -> float:
    try:
        length = float(length)
    except (TypeError, ValueError) as e:
        raise FormatError(f"segment length: expected a number, found {length!r}") from e
    if not math.isfinite(length) or length < 0:
        raise FormatError(f"segment length: expected a finite number >= 0, found {length}")
    return length


def extinction(a: np.ndarray) -> np.ndarray:
    """Extinction per voxel ``-ln(1 - a)``, capped at :data:`TAU_MAX` (``a = 1`` included)."""
    a = np.asarray(a, dtype=np.float64)
    tau = np.full(a.shape, TAU_MAX)
    ok = a < 1.0
    tau[ok] = np.minimum(-np.log1p(-a[ok]), TAU_MAX)
    return tau


def _iso_prepare(n, lo, hi, isos):
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise FormatError(f"iso table size: expected an integer >= 1, found {n!r}")
    lo, hi = check_range(lo, hi, "iso table range")
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
def _preint_fast_kernel(tau, col, length, engel, out, k0, k1):
    """Integral-function tables (see ``fast`` / ``engel`` in the module docstring), the
    entries whose segment touches table entries ``k0 .. k1`` (all for ``0, n - 1``).

    With seven channels, ``B = C w`` where ``w`` is the emission-weighted mean position
    of the segment (0 at the front, 1 at the back), from the first-moment prefix
    integral ``M(s) = int s c tau`` (Simpson, exact for the cubic integrand).
    """
    n = tau.shape[0]
    lit = out.shape[2] == 7
    tp, kp, mp = prefix_integrals(tau, col, lit)
    for i in range(n):
        for j in range(n):
            if (i < k0 and j < k0) or (i > k1 and j > k1):
                continue
            if i == j:
                a = -math.expm1(-tau[i] * length)
                out[i, j, 3] = a
                for ch in range(3):
                    if engel:
                        out[i, j, ch] = col[i, ch] * tau[i] * length
                    else:
                        out[i, j, ch] = col[i, ch] * a
                    if lit:
                        out[i, j, 4 + ch] = 0.5 * out[i, j, ch]
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
                if lit:
                    # int (s - i) c tau ds over the segment, divided by (j - i) int c tau
                    den = (j - i) * (kp[j, ch] - kp[i, ch])
                    w = 0.5
                    if den > 0.0:
                        w = ((mp[j, ch] - mp[i, ch]) - i * (kp[j, ch] - kp[i, ch])) / den
                        w = min(max(w, 0.0), 1.0)
                    out[i, j, 4 + ch] = out[i, j, ch] * w


@kernel
def _cell_integral_kernel(t_in, t_out, delta):
    """Opacity ``alpha``, ``J = int_0^1 W(u) du`` and ``J1 = int_0^1 u W(u) du`` of one
    TF cell, with ``W(u) = 1 - exp(-Phi(u))`` the opacity of its first ``u``.

    The cell is crossed over ``delta`` voxels with extinction going linearly from
    ``t_in`` to ``t_out``: ``Phi(u) = delta (t_in u + (t_out - t_in) u^2 / 2)``.
    Composite 3-point Gauss-Legendre, one sub-interval per unit of the largest
    ``delta * tau`` (at most 256). ``0 <= J <= alpha`` and ``0 <= J1 <= J`` are enforced.
    ``W`` saturates smoothly, so it integrates well where ``tau exp(-Phi)``, peaked at
    the entry of an opaque cell, would not; the colour integrals are taken by parts.
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
    acc1 = 0.0
    for k in range(nsub):
        u = (k + x0) * h
        v = (5.0 / 18.0) * -math.expm1(-delta * u * (t_in + half_slope * u))
        acc += v
        acc1 += u * v
        u = (k + 0.5) * h
        v = (8.0 / 18.0) * -math.expm1(-delta * u * (t_in + half_slope * u))
        acc += v
        acc1 += u * v
        u = (k + x2) * h
        v = (5.0 / 18.0) * -math.expm1(-delta * u * (t_in + half_slope * u))
        acc += v
        acc1 += u * v
    j = acc * h
    if j < 0.0:
        j = 0.0
    if j > alpha:
        j = alpha
    j1 = acc1 * h
    if j1 < 0.0:
        j1 = 0.0
    if j1 > j:
        j1 = j
    return alpha, j, j1


@kernel(inline=True)
def _cell_run(c, t, f, k, ec, et, ef, lit):
    """Start a run of cells ``(C, T, F)`` at cell ``k``: the cell alone."""
    t[k] = et[k]
    for ch in range(3):
        c[k, ch] = ec[k, ch]
        if lit:
            f[k, ch] = ef[k, ch]


@kernel
def _window_over_kernel(ec, et, ef, m, lit, pre_c, pre_t, pre_f, suf_c, suf_t, suf_f, res, resf):
    """Composite every window of ``m`` consecutive cells front to back ("over").

    ``ec[k]`` is the premultiplied colour and ``et[k]`` the transmittance of cell ``k``
    in ray order. ``res[f]`` receives the colour of cells ``f .. f+m-1``. Blocks of
    ``m`` cells get prefix and suffix composites; a window is one suffix over one
    prefix, so the whole pass is O(cells) and never divides.

    With ``lit``, ``ef[k]`` is the cell's colour weighted by the position inside it
    (0 at entry, 1 at exit) and ``resf[f]`` receives ``sum_q T_q (q ec + ef)`` over the
    window's cells ``q = 0 .. m-1`` (``T_q`` the transmittance in front of cell ``q``):
    ``m`` times the colour weighted by the position along the whole window. A run of
    cells is ``(C, T, F, N)`` and ``X over Y`` is
    ``(C_X + T_X C_Y, T_X T_Y, F_X + T_X (F_Y + N_X C_Y), N_X + N_Y)``, still associative.
    """
    nc = et.shape[0]
    for k in range(nc):
        q = k % m
        if q == 0:
            _cell_run(pre_c, pre_t, pre_f, k, ec, et, ef, lit)
        else:
            pre_t[k] = pre_t[k - 1] * et[k]
            for ch in range(3):
                pre_c[k, ch] = pre_c[k - 1, ch] + pre_t[k - 1] * ec[k, ch]
                if lit:
                    pre_f[k, ch] = pre_f[k - 1, ch] + pre_t[k - 1] * (q * ec[k, ch] + ef[k, ch])
    for k in range(nc - 1, -1, -1):
        if k % m == m - 1 or k == nc - 1:
            _cell_run(suf_c, suf_t, suf_f, k, ec, et, ef, lit)
        else:
            suf_t[k] = et[k] * suf_t[k + 1]
            for ch in range(3):
                suf_c[k, ch] = ec[k, ch] + et[k] * suf_c[k + 1, ch]
                if lit:
                    suf_f[k, ch] = ef[k, ch] + et[k] * (suf_f[k + 1, ch] + suf_c[k + 1, ch])
    for f in range(nc - m + 1):
        e = f + m - 1
        if f % m == 0:
            for ch in range(3):
                res[f, ch] = pre_c[e, ch]
                if lit:
                    resf[f, ch] = pre_f[e, ch]
        else:
            nsuf = m - f % m  # cells of the suffix part
            for ch in range(3):
                res[f, ch] = suf_c[f, ch] + suf_t[f] * pre_c[e, ch]
                if lit:
                    resf[f, ch] = suf_f[f, ch] + suf_t[f] * (pre_f[e, ch] + nsuf * pre_c[e, ch])


@kernel
def _exact_diagonal_kernel(tau, col, length, lit, lo, hi, out):
    """Constant-scalar entries ``(i, i)`` for ``lo <= i < hi``."""
    for i in range(lo, hi):
        a = -math.expm1(-tau[i] * length)
        out[i, i, 3] = a
        back = 0.0  # share of the emission of a constant segment weighted by position
        if lit:
            _, jw, _ = _cell_integral_kernel(tau[i], tau[i], length)
            back = (a - jw) / a if a > 0.0 else 0.5
        for ch in range(3):
            out[i, i, ch] = col[i, ch] * a
            if lit:
                out[i, i, 4 + ch] = col[i, ch] * a * back


@kernel
def _exact_cells_kernel(tau, col, delta, lit, lo, hi, up_c, up_f, up_t, dn_c, dn_f, dn_t):
    """Colour, position moment and transmittance of TF cells ``lo <= k < hi`` crossed
    over ``delta`` voxels, upward (enter at k) and downward (enter at k + 1).

    Downward arrays are in ray order: entry ``nc - 1 - k`` is cell ``k``.
    """
    nc = up_t.shape[0]
    for k in range(lo, hi):
        t = math.exp(-delta * 0.5 * (tau[k] + tau[k + 1]))
        alpha, jw, j1 = _cell_integral_kernel(tau[k], tau[k + 1], delta)
        up_t[k] = t
        for ch in range(3):
            ci = col[k, ch]
            co = col[k + 1, ch]
            up_c[k, ch] = ci * jw + co * (alpha - jw)
            if lit:  # int u c dW by parts
                up_f[k, ch] = co * alpha - ci * jw - 2.0 * (co - ci) * j1
        alpha, jw, j1 = _cell_integral_kernel(tau[k + 1], tau[k], delta)
        r = nc - 1 - k
        dn_t[r] = t
        for ch in range(3):
            ci = col[k + 1, ch]
            co = col[k, ch]
            dn_c[r, ch] = ci * jw + co * (alpha - jw)
            if lit:
                dn_f[r, ch] = co * alpha - ci * jw - 2.0 * (co - ci) * j1


@kernel(inline=True)
def _segments(n):
    """Scratch for ``n`` segments: colour, lit colour (zero: unlit tables leave it) and
    optical depth."""
    return np.empty((n, 3)), np.zeros((n, 3)), np.empty(n)


@kernel
def _exact_windows_kernel(tp, length, m, lit, f_lo, f_hi, up_c, up_f, up_t, dn_c, dn_f, dn_t, out):
    """Entries ``(f, f + m)`` and ``(f + m, f)`` for ``f_lo <= f < f_hi``: the windows of
    ``m`` cells composited from the cell arrays (only the cells they cover are read)."""
    nc = up_t.shape[0]
    c_lo = f_lo
    c_hi = f_hi + m - 1  # cells f_lo .. f_hi + m - 2
    w = c_hi - c_lo
    if w < m:
        return
    pre_c, pre_f, pre_t = _segments(w)
    suf_c, suf_f, suf_t = _segments(w)
    res_up = np.empty((w, 3))
    res_dn = np.empty((w, 3))
    resf_up = np.empty((w, 3))
    resf_dn = np.empty((w, 3))
    _window_over_kernel(
        up_c[c_lo:c_hi], up_t[c_lo:c_hi], up_f[c_lo:c_hi], m, lit,
        pre_c, pre_t, pre_f, suf_c, suf_t, suf_f, res_up, resf_up,
    )  # fmt: skip
    r_lo = nc - c_hi
    r_hi = nc - c_lo
    _window_over_kernel(
        dn_c[r_lo:r_hi], dn_t[r_lo:r_hi], dn_f[r_lo:r_hi], m, lit,
        pre_c, pre_t, pre_f, suf_c, suf_t, suf_f, res_dn, resf_dn,
    )  # fmt: skip
    for f in range(f_lo, f_hi):
        # upward segment f -> f + m covers cells f .. f + m - 1
        b = f + m
        a = -math.expm1(-length * (tp[b] - tp[f]) / m)
        out[f, b, 3] = a
        out[b, f, 3] = a
        # downward segment b -> f covers, in ray order, reversed cells nc - b ..
        u = f - c_lo
        d = nc - b - r_lo
        for ch in range(3):
            cu = min(max(res_up[u, ch], 0.0), a)
            out[f, b, ch] = cu
            cd = min(max(res_dn[d, ch], 0.0), a)
            out[b, f, ch] = cd
            if lit:
                out[f, b, 4 + ch] = min(max(resf_up[u, ch] / m, 0.0), cu)
                out[b, f, 4 + ch] = min(max(resf_dn[d, ch] / m, 0.0), cd)


@kernel
def prefix_integrals(tau, col, moments):
    """Prefix integrals over index units, exact for ``tau`` and ``c`` linear between
    entries: ``T(s) = int tau``, ``K(s) = int c tau`` and, with ``moments``,
    ``M(s) = int s c tau`` (Simpson, exact for the cubic integrand; zeros otherwise)."""
    n = tau.shape[0]
    tp = np.zeros(n)
    kp = np.zeros((n, 3))
    mp = np.zeros((n, 3))
    for k in range(n - 1):
        t0 = tau[k]
        t1 = tau[k + 1]
        tp[k + 1] = tp[k] + 0.5 * (t0 + t1)
        th = 0.5 * (t0 + t1)
        for ch in range(3):
            c0 = col[k, ch]
            c1 = col[k + 1, ch]
            kp[k + 1, ch] = kp[k, ch] + (2.0 * c0 * t0 + c0 * t1 + c1 * t0 + 2.0 * c1 * t1) / 6.0
            if moments:
                f0 = k * c0 * t0
                cm = 0.5 * (c0 + c1)
                fh = (k + 0.5) * cm * th
                f1 = (k + 1.0) * c1 * t1
                mp[k + 1, ch] = mp[k, ch] + (f0 + 4.0 * fh + f1) / 6.0
    return tp, kp, mp


@kernel
def _preint_exact_kernel(tau, col, length, out):
    """Exact tables with self-attenuation (see ``exact`` in the module docstring)."""
    n = tau.shape[0]
    lit = out.shape[2] == 7
    tp = prefix_integrals(tau, col, False)[0]
    _exact_diagonal_kernel(tau, col, length, lit, 0, n, out)
    nc = n - 1
    if nc < 1:
        return
    up_c, up_f, up_t = _segments(nc)
    dn_c, dn_f, dn_t = _segments(nc)
    for m in range(1, n):
        _exact_cells_kernel(tau, col, length / m, lit, 0, nc, up_c, up_f, up_t, dn_c, dn_f, dn_t)
        _exact_windows_kernel(tp, length, m, lit, 0, n - m, up_c, up_f, up_t, dn_c, dn_f, dn_t, out)


@kernel
def _exact_update_kernel(tau, col, length, k0, k1, cache_c, cache_f, cache_t, out):
    """Exact entries whose segment touches table entries ``k0 .. k1`` (inclusive), from
    the per-length cell cache (``cache_*[m - 1]``: upward then downward cells), whose
    cells ``k0 - 1 .. k1`` are recomputed first."""
    n = tau.shape[0]
    lit = out.shape[2] == 7
    tp = prefix_integrals(tau, col, False)[0]
    _exact_diagonal_kernel(tau, col, length, lit, k0, k1 + 1, out)
    nc = n - 1
    if nc < 1:
        return
    c_lo = max(k0 - 1, 0)
    c_hi = min(k1 + 1, nc)
    for m in range(1, n):
        up_c, dn_c = cache_c[m - 1, 0], cache_c[m - 1, 1]
        up_f, dn_f = cache_f[m - 1, 0], cache_f[m - 1, 1]
        up_t, dn_t = cache_t[m - 1, 0], cache_t[m - 1, 1]
        _exact_cells_kernel(
            tau, col, length / m, lit, c_lo, c_hi, up_c, up_f, up_t, dn_c, dn_f, dn_t
        )
        # windows f .. f + m - 1 that meet cells c_lo .. c_hi - 1
        f_lo = max(c_lo - m + 1, 0)
        f_hi = min(c_hi, n - m)
        if f_hi > f_lo:
            _exact_windows_kernel(
                tp, length, m, lit, f_lo, f_hi, up_c, up_f, up_t, dn_c, dn_f, dn_t, out
            )


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
