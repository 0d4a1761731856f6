"""One level of a reversible 1-D integer lifting transform, applied to every line of a region.

A level first splits a line of length ``n`` into its even samples (moved to ``[0, ns)``,
``ns = ceil(n/2)``) and its odd samples (moved to ``[ns, n)``), then runs the wavelet's
lifting steps in place on these two contiguous halves. The inverse runs the steps
backwards with the opposite sign and interleaves the halves again. Splitting first keeps
every lifting step a unit-stride loop over contiguous memory.

A wavelet is a small int64 table, one row per lifting step (see :data:`SPECS`)::

    target  kind  add  shift  mode  o0 o1 o2 o3

``target`` 1 means the step updates the odd (high-pass) half by *subtracting*
``v``; 0 means it updates the even (low-pass) half by *adding* ``v``, with::

    v = (combine(src[k+o0], src[k+o1], src[k+o2], src[k+o3]) + add) >> shift

and ``src`` the other half. ``>>`` on signed integers floors, so ``v`` is
``floor((combine + add) / 2**shift)``. ``combine`` depends on ``kind``:

====  ===============================
kind  combine
====  ===============================
1     ``x0``
2     ``x0 + x1``
3     ``x0 - x1``
4     ``9*(x1 + x2) - (x0 + x3)``
====  ===============================

Unused offsets repeat ``o0``. A source index outside its half is mapped back by
``mode``:

* ``WSS`` (5/3, 9/7-M): whole-sample symmetric extension of the *signal*: the sample
  position ``2j`` or ``2j+1`` is mirrored about ``0`` and ``n-1`` (as often as needed,
  so lengths 2 and 3 work too), which keeps its parity. This is exactly the lifting of
  the mirrored infinite signal, as in JPEG 2000.
* ``HSS`` (third step of 2/6): half-sample symmetric extension of the low half
  (``s[-1] = s[0]``, ``s[ns] = s[ns-1]``), which is what the S-transform of a
  half-sample-symmetric signal gives.
* ``ZERO`` (Haar pair steps): a missing partner contributes nothing; the unpaired last
  even sample of an odd-length line is copied to the low half unchanged (again what a
  half-sample-symmetric extension, ``x[n] = x[n-1]``, gives: its detail is 0).

Every kernel computes in int64 registers and stores to the work dtype; the caller
(:func:`volpack.wavelet.dwt3.work_dtype`) proves that stored values fit.
"""

from __future__ import annotations

import numpy as np

from volpack._jit import kernel

WSS, HSS, ZERO = 0, 1, 2

# Forward steps, in order. Odd-target steps subtract, even-target steps add.
SPECS = {
    # d[k] = x[2k+1] - floor((x[2k] + x[2k+2]) / 2); s[k] = x[2k] + floor((d[k-1] + d[k] + 2) / 4)
    "53": np.array(
        [[1, 2, 0, 1, WSS, 0, 1, 0, 0], [0, 2, 2, 2, WSS, -1, 0, -1, -1]], dtype=np.int64
    ),
    # d = x_odd - floor((9 (e[k] + e[k+1]) - (e[k-1] + e[k+2]) + 8) / 16); s as for 5/3
    "97m": np.array(
        [[1, 4, 8, 4, WSS, -1, 0, 1, 2], [0, 2, 2, 2, WSS, -1, 0, -1, -1]], dtype=np.int64
    ),
    # S-transform: d = x1 - x0; s = x0 + floor(d / 2)
    "haar": np.array(
        [[1, 1, 0, 0, ZERO, 0, 0, 0, 0], [0, 1, 0, 1, ZERO, 0, 0, 0, 0]], dtype=np.int64
    ),
    # S-transform, then d += floor((s[k-1] - s[k+1] + 2) / 4), written as the equal
    # d -= floor((s[k+1] - s[k-1] + 1) / 4)  (since -floor(y/4) == floor((3-y)/4)).
    "26": np.array(
        [
            [1, 1, 0, 0, ZERO, 0, 0, 0, 0],
            [0, 1, 0, 1, ZERO, 0, 0, 0, 0],
            [1, 3, 1, 2, HSS, 1, -1, 1, 1],
        ],
        dtype=np.int64,
    ),
}


@kernel
def _resolve_kernel(j, ms, mode, n, parity):
    """Index into a half of length ``ms`` for source index ``j``; -1 if it has no value."""
    if 0 <= j < ms:
        return j
    if mode == WSS:
        period = 2 * (n - 1)
        p = (2 * j + parity) % period
        if p >= n:
            p = period - p
        return (p - parity) // 2
    if mode == HSS:
        period = 2 * ms
        j = j % period
        if j >= ms:
            j = period - 1 - j
        return j
    return -1


@kernel
def _value_kernel(kind, x0, x1, x2, x3, add, shift):
    """The lifting correction ``v`` of one sample (int64 arithmetic)."""
    x0 = np.int64(x0)
    x1 = np.int64(x1)
    if kind == 1:
        c = x0
    elif kind == 2:
        c = x0 + x1
    elif kind == 3:
        c = x0 - x1
    else:
        c = 9 * (x1 + np.int64(x2)) - (x0 + np.int64(x3))
    return (c + add) >> shift


@kernel
def _halves_kernel(step, n, ns, backward):
    """Geometry of one step: target start and length, source start, length and parity, sign."""
    if step[0] == 1:
        t0, mt, s0, ms, parity, sign = ns, n - ns, 0, ns, 0, -1
    else:
        t0, mt, s0, ms, parity, sign = 0, ns, ns, n - ns, 1, 1
    if backward:
        sign = -sign
    return t0, mt, s0, ms, parity, sign


@kernel
def _step_row_kernel(row, n, ns, step, backward):
    """Apply one lifting step (or its inverse) to a split contiguous line ``row[:n]``."""
    t0, mt, s0, ms, parity, sign = _halves_kernel(step, n, ns, backward)
    kind, add, shift = step[1], step[2], step[3]
    o0, o1, o2, o3 = step[5], step[6], step[7], step[8]
    omin = min(min(o0, o1), min(o2, o3))
    omax = max(max(o0, o1), max(o2, o3))
    kb = min(mt, max(0, -omin))
    ke = max(kb, min(mt, ms - omax))
    # interior: every source index is in range
    for k in range(kb, ke):
        b = s0 + k
        row[t0 + k] += sign * _value_kernel(
            kind, row[b + o0], row[b + o1], row[b + o2], row[b + o3], add, shift
        )
    # the few samples near either end, with mirrored source indices
    for k in range(kb):
        _edge_row_kernel(row, n, k, t0, s0, ms, parity, sign, step)
    for k in range(ke, mt):
        _edge_row_kernel(row, n, k, t0, s0, ms, parity, sign, step)


@kernel
def _edge_row_kernel(row, n, k, t0, s0, ms, parity, sign, step):
    """Update target sample ``k`` of a split line, mirroring source indices as needed."""
    mode = step[4]
    j0 = _resolve_kernel(k + step[5], ms, mode, n, parity)
    j1 = _resolve_kernel(k + step[6], ms, mode, n, parity)
    j2 = _resolve_kernel(k + step[7], ms, mode, n, parity)
    j3 = _resolve_kernel(k + step[8], ms, mode, n, parity)
    if j0 < 0 or j1 < 0 or j2 < 0 or j3 < 0:
        return
    v = _value_kernel(
        step[1], row[s0 + j0], row[s0 + j1], row[s0 + j2], row[s0 + j3], step[2], step[3]
    )
    row[t0 + k] += sign * v


@kernel
def lift_rows_kernel(a, n0, n1, n, tmp, spec, backward):
    """One level along the last (contiguous) axis of ``a[:n0, :n1, :n]``, every row.

    Forward (``backward`` False): split each row into evens then odds, then run the
    steps of ``spec``. Backward: undo the steps in reverse order, then interleave.
    ``tmp`` holds at least ``n // 2`` values.
    """
    ns = (n + 1) // 2
    nd = n - ns
    nsteps = spec.shape[0]
    for i in range(n0):
        for j in range(n1):
            row = a[i, j]
            if not backward:
                for k in range(nd):
                    tmp[k] = row[2 * k + 1]
                for k in range(1, ns):
                    row[k] = row[2 * k]
                for k in range(nd):
                    row[ns + k] = tmp[k]
                for s in range(nsteps):
                    _step_row_kernel(row, n, ns, spec[s], backward)
            else:
                for s in range(nsteps - 1, -1, -1):
                    _step_row_kernel(row, n, ns, spec[s], backward)
                for k in range(nd):
                    tmp[k] = row[ns + k]
                for k in range(ns - 1, 0, -1):
                    row[2 * k] = row[k]
                for k in range(nd):
                    row[2 * k + 1] = tmp[k]


@kernel
def _step_planes_kernel(b, n, ns, nq, nr, step, backward):
    """Apply one lifting step to a split block ``b[:n, :nq, :nr]`` along its first axis.

    The inner loops run over whole ``(nq, nr)`` slabs, contiguous in the last axis.
    """
    t0, mt, s0, ms, parity, sign = _halves_kernel(step, n, ns, backward)
    kind, add, shift, mode = step[1], step[2], step[3], step[4]
    for k in range(mt):
        j0 = _resolve_kernel(k + step[5], ms, mode, n, parity)
        j1 = _resolve_kernel(k + step[6], ms, mode, n, parity)
        j2 = _resolve_kernel(k + step[7], ms, mode, n, parity)
        j3 = _resolve_kernel(k + step[8], ms, mode, n, parity)
        if j0 < 0 or j1 < 0 or j2 < 0 or j3 < 0:
            continue
        t = b[t0 + k]
        x0 = b[s0 + j0]
        x1 = b[s0 + j1]
        x2 = b[s0 + j2]
        x3 = b[s0 + j3]
        for q in range(nq):
            for r in range(nr):
                t[q, r] += sign * _value_kernel(
                    kind, x0[q, r], x1[q, r], x2[q, r], x3[q, r], add, shift
                )


@kernel
def lift_planes_kernel(a4, np_, n, nq, nr, tmp, spec, backward):
    """One level along axis 1 of the 4-D view ``a4[:np_, :n, :nq, :nr]``.

    With ``a`` a C-contiguous ``(Z, Y, X)`` array, ``a.reshape(1, Z, Y, X)`` lifts along z
    vectorised over whole ``(y, x)`` planes, and ``a.reshape(Z, Y, 1, X)`` lifts along y
    vectorised over x rows. ``tmp`` holds at least ``(n // 2) * nq * nr`` values.
    """
    ns = (n + 1) // 2
    nd = n - ns
    nsteps = spec.shape[0]
    t3 = tmp[: nd * nq * nr].reshape((nd, nq, nr))
    for p in range(np_):
        b = a4[p]
        if not backward:
            for k in range(nd):
                src = b[2 * k + 1]
                dst = t3[k]
                for q in range(nq):
                    for r in range(nr):
                        dst[q, r] = src[q, r]
            for k in range(1, ns):
                src = b[2 * k]
                dst = b[k]
                for q in range(nq):
                    for r in range(nr):
                        dst[q, r] = src[q, r]
            for k in range(nd):
                src = t3[k]
                dst = b[ns + k]
                for q in range(nq):
                    for r in range(nr):
                        dst[q, r] = src[q, r]
            for s in range(nsteps):
                _step_planes_kernel(b, n, ns, nq, nr, spec[s], backward)
        else:
            for s in range(nsteps - 1, -1, -1):
                _step_planes_kernel(b, n, ns, nq, nr, spec[s], backward)
            for k in range(nd):
                src = b[ns + k]
                dst = t3[k]
                for q in range(nq):
                    for r in range(nr):
                        dst[q, r] = src[q, r]
            for k in range(ns - 1, 0, -1):
                src = b[k]
                dst = b[2 * k]
                for q in range(nq):
                    for r in range(nr):
                        dst[q, r] = src[q, r]
            for k in range(nd):
                src = t3[k]
                dst = b[2 * k + 1]
                for q in range(nq):
                    for r in range(nr):
                        dst[q, r] = src[q, r]
