"""The cut-border machine: one numba kernel that both encodes and decodes.

The encoder and the decoder run the *same* state machine over the same cut-border; they
differ only where an operation is chosen (the encoder looks it up in the mesh, the decoder
reads it from the stream). Every binary decision therefore goes through :func:`_bit`,
which encodes the given bit or decodes and returns one, so that the binarisation of each
symbol is written once and cannot drift between the two sides.

The cut-border is a triangle surface kept in one int32 table ``T`` (one row per
triangle, rows reused through a free list):

``V0..V2``  vertices (coding order), oriented with the normal out of the inner part
``A0..A2``  the triangle across edge k = (V[k], V[k+1]); at an edge with more than two
            cut-border triangles, triangles bounding the same outer region are paired
``INNER``   coding index of the inner tetrahedron (the parent of the next one)
``ZF``      zero edge (bits 0-1) and the mesh-border flag (bit 2)
``N0..N2``  next / ``P0..P2`` previous incidence in the vertex lists
``F0..F2``  fan: coded tetrahedra around edge k on the triangle's inner side (a cheap
            edge valence: a fan near five tetrahedra is about to be closed by connect 0)

Each vertex keeps the list of its cut-border triangles (incidence slot ``3 t + k``), so
that faces and edges are found by scanning the shorter list: that is the thesis's
"set of adjacent triangles" with insert, erase and intersection.

It stays one file of about 1,000 lines on purpose: the encoder and the decoder are one
state machine in one kernel with its inline helpers, so splitting it would split what must
not drift apart.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel, leading_zeros
from ..entropy.rangecoder import PROB_BITS, get_decision, get_raw, put_decision, put_raw
from .mesh import HUB, PARITY, bucket_faces

# Adaptation rate by use count: as the wavelet coder's early on, but settling at 1/64:
# one mesh is one long stationary stream (the wavelet coder's bricks are short).
RATE = np.array([1, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 6], dtype=np.int64)

# --- triangle table columns ---
V0, A0, INNER, ZF, NX, PV = 0, 3, 6, 7, 8, 11
FAN = 14  # FAN0..FAN2: inner tetrahedra around edge k on this triangle's inner side
TCOLS = 17
FLAG = 4

# --- the stream's adaptive models (binary contexts) ---
M_OP = 0  # decision 0 of the operation tree (connect 0?): 64 contexts, see _op_context
N_OPCTX = 64
M_OPR = M_OP + N_OPCTX  # decisions 1..5: 32 contexts (see _rest_context) x 5
N_RESTCTX = 32
M_IDX = M_OPR + 5 * N_RESTCTX  # connect index - 3: exp-Golomb, 64 models
M_FAR = M_IDX + 64  # distance back to a known vertex: exp-Golomb, 64 models
M_KNOWN = M_FAR + 64  # first tet of a component: is this vertex already known?
M_ORI = M_KNOWN + 1  # orientation exception of a tet (2 contexts: previous flag)
N_MODELS = M_ORI + 2

# Initial probability of a 0 for the six operation decisions (1 = "yes, it is this one"),
# from the thesis's average operation frequencies (Table 3.6): connect 0 0.602, new vertex
# 0.176, connect 1 0.084, connect 2 0.076, connect >2 0.060, border 0.001.
OP_P0 = np.array([0.398, 0.558, 0.622, 0.449, 0.032, 0.5])
INIT_USES = 6  # a prior worth a few dozen operations: adapts at 1/8, then 1/16, ...

# Enumeration limits (identical on both sides): beyond them a vertex is coded as "far".
MAX_INDEX = 4096
MAX_VISIT = 32768

# Operation kinds.
K_CONN, K_NEW, K_FAR, K_BORDER = 0, 1, 2, 3

# Status codes of the kernel.
OK, E_SHORT, E_SYMBOL, E_OVERFLOW = 0, 1, 2, -1

# Statistic counters (encoder): index -> name in cutborder.STAT_NAMES.
S_OPS, S_DELTA, S_BORDER_CONN, S_NEW, S_FAR, S_CONN = 0, 1, 2, 3, 4, 5
S_FLIP, S_NMFLIP, S_TOP, S_CLOSE, S_JOIN0 = 6, 7, 8, 9, 10  # joins with 0..3 nm edges: 10..13
S_REVISIT, S_COMPONENTS, S_ORI = 14, 15, 16
N_STATS = 17
# Cost categories (bits, from the model probabilities).
C_OP, C_IDX, C_FAR, C_ORI, C_START, C_BORDER = 0, 1, 2, 3, 4, 5
N_COST = 6


def initial_models() -> np.ndarray:
    st = np.full(N_MODELS, ((1 << (PROB_BITS - 1)) << 4), dtype=np.uint16)
    for j in range(6):
        p = int(round(OP_P0[j] * (1 << PROB_BITS)))
        if j == 0:
            st[M_OP : M_OP + N_OPCTX] = (p << 4) | INIT_USES
        else:
            st[M_OPR + j - 1 : M_OPR + 5 * N_RESTCTX : 5] = (p << 4) | INIT_USES
    return st


# ---------------------------------------------------------------- the binary coder
# cs: int64 coder state [low or code, range, position, buffer size, measuring, category]


@kernel
def _bit(cs, buf, st, cost, k, bit, dec):
    """Encode ``bit`` with model ``k`` (or decode one when ``dec``); return the bit.
    When measuring (``cs[4]``), the bit's cost under the model before it adapts is
    added to category ``cs[5]``."""
    p = np.int64(st[k]) >> 4
    if dec:
        bit = get_decision(cs, buf, st, k, RATE)
    else:
        put_decision(cs, buf, st, k, bit, RATE)
    if cs[4]:
        q = p / (1 << PROB_BITS)
        cost[cs[5]] -= math.log2(1.0 - q if bit else q)
    return bit


@kernel
def _flat(cs, buf, v, t, dec):
    """Encode (or decode) ``t`` <= 16 bits at probability one half."""
    if dec:
        v = np.int64(get_raw(cs, buf, t))
    else:
        put_raw(cs, buf, np.uint64(v), t)
    if cs[4]:
        cs[6] += t  # flat bits are counted in whole bits (category of the caller)
    return v


@kernel
def _uint(cs, buf, st, cost, base, v, dec):
    """Exp-Golomb code of ``v >= 0``: bit length in unary (adaptive), then its bits.

    Models ``base + 0..30`` code the unary length, ``base + 32 + n`` the bit below the
    leading one of an n-bit value; lower bits are flat. Returns -1 on a corrupt length.
    """
    w = v + 1
    nb = 64 - np.int64(leading_zeros(np.uint64(w))) if not dec else 0
    n = 1
    while True:
        more = _bit(cs, buf, st, cost, base + min(n - 1, 30), np.int64(nb > n), dec)
        if more == 0:
            break
        n += 1
        if n > 40:
            return -1
    if n == 1:
        return 0
    b = _bit(cs, buf, st, cost, base + 32 + min(n, 31), (w >> (n - 2)) & 1, dec)
    val = 2 + b
    rest = n - 2
    flat0 = cs[6]
    while rest > 0:
        t = min(rest, 16)
        rest -= t
        f = _flat(cs, buf, (w >> rest) & ((1 << t) - 1), t, dec)
        val = (val << t) | f
    if cs[4]:
        cost[cs[5]] += cs[6] - flat0
        cs[6] = flat0
    return val - 1


# ---------------------------------------------------------------- the cut-border


@kernel
def _link(T, head, tail, deg, t):
    """Append t to the triangle lists of its vertices (oldest first: the gate order)."""
    for k in range(3):
        v = T[t, k]
        s = 3 * t + k
        last = tail[v]
        T[t, NX + k] = -1
        T[t, PV + k] = last
        if last >= 0:
            T[last // 3, NX + last % 3] = s
        else:
            head[v] = s
        tail[v] = s
        deg[v] += 1


@kernel
def _unlink(T, head, tail, deg, t):
    for k in range(3):
        v = T[t, k]
        nx = T[t, NX + k]
        pv = T[t, PV + k]
        if pv >= 0:
            T[pv // 3, NX + pv % 3] = nx
        else:
            head[v] = nx
        if nx >= 0:
            T[nx // 3, PV + nx % 3] = pv
        else:
            tail[v] = pv
        deg[v] -= 1


@kernel
def _find_face(T, head, deg, a, b, c):
    """The cut-border triangle with vertices {a, b, c}, or -1."""
    v, x, y = a, b, c
    if deg[b] < deg[v]:
        v, x, y = b, a, c
    if deg[c] < deg[v]:
        v, x, y = c, a, b
    s = head[v]
    while s >= 0:
        t = s // 3
        k = s % 3
        p = T[t, (k + 1) % 3]
        q = T[t, (k + 2) % 3]
        if (p == x and q == y) or (p == y and q == x):
            return t
        s = T[t, NX + k]
    return -1


@kernel
def _edge_slot(T, t, u, v):
    """k such that edge k = (V[k], V[k+1]) of triangle t is {u, v}; -1 if none."""
    for k in range(3):
        p = T[t, k]
        q = T[t, (k + 1) % 3]
        if (p == u and q == v) or (p == v and q == u):
            return k
    return -1


@kernel
def _pair(T, t1, t2, u, v):
    """Make t1 and t2 neighbours across edge {u, v}; False if either lacks the edge."""
    if t1 < 0 or t2 < 0:
        return False
    k1 = _edge_slot(T, t1, u, v)
    k2 = _edge_slot(T, t2, u, v)
    if k1 < 0 or k2 < 0:
        return False
    T[t1, A0 + k1] = t2
    T[t2, A0 + k2] = t1
    return True


@kernel
def _across(T, t, u, v):
    k = _edge_slot(T, t, u, v)
    return T[t, A0 + k] if k >= 0 else -1


@kernel
def _edge_tri(T, head, deg, u, v):
    """A cut-border triangle holding edge u -> v, else one holding v -> u (as ~t), else -1.

    Returned as t when the triangle has the directed edge u -> v, as -2 - t otherwise.
    """
    w, x = u, v
    if deg[v] < deg[u]:
        w, x = v, u
    s = head[w]
    other = -1
    while s >= 0:
        t = s // 3
        k = s % 3
        if T[t, (k + 1) % 3] == x:  # w -> x in t
            if w == u:
                return t
            if other < 0:
                other = -2 - t
        elif T[t, (k + 2) % 3] == x:  # x -> w in t
            if w == v:
                return t
            if other < 0:
                other = -2 - t
        s = T[t, NX + k]
    return other


@kernel
def _enumerate(T, g, z, target_v, target_i, tstamp, vstamp, stamp, queue, first):
    """Breadth-first connect numbering from gate g, zero edge z (thesis Fig. 3.20).

    Stops at vertex ``target_v`` (returns its index) or at index ``target_i`` (returns the
    vertex as ``-2 - vertex``); -1 when neither is reached within the limits. The first
    three vertices numbered are stored in ``first``.
    """
    tstamp[g] = stamp
    for k in range(3):
        vstamp[T[g, k]] = stamp
        first[k] = -1
    qt = 0
    for k in range(3):
        queue[qt] = 3 * g + (z + k) % 3
        qt += 1
    qh = 0
    count = 0
    visits = 0
    while qh < qt:
        e = queue[qh]
        qh += 1
        t = e // 3
        k = e % 3
        n = T[t, A0 + k]
        if n < 0 or tstamp[n] == stamp:
            continue
        tstamp[n] = stamp
        visits += 1
        if visits > MAX_VISIT:
            return -1
        j = _edge_slot(T, n, T[t, k], T[t, (k + 1) % 3])
        if j < 0:
            return -1
        x = T[n, (j + 2) % 3]
        if vstamp[x] != stamp:
            vstamp[x] = stamp
            if count < 3:
                first[count] = x
            if x == target_v:
                return count
            if count == target_i:
                return -2 - x
            count += 1
            if count >= MAX_INDEX:
                return -1
        queue[qt] = 3 * n + (j + 1) % 3
        queue[qt + 1] = 3 * n + (j + 2) % 3
        qt += 2
    return -1


@kernel
def _new_vertex(vi, nvc, nvu, dec, vcode, vorder):
    """The code number of a vertex met for the first time: ``nvc``, the count so far (the
    encoder records the input vertex ``vi`` under it both ways); -1 past ``nvu``."""
    if nvc >= nvu:
        return -1
    if not dec:
        vcode[vi] = nvc
        vorder[nvc] = vi
    return nvc


@kernel
def _alloc(T, free, nfree, bump):
    """Row for a new triangle: (row, nfree, bump)."""
    if nfree > 0:
        nfree -= 1
        return free[nfree], nfree, bump
    return bump, nfree, bump + 1


@kernel
def _push(v, fifo, fh, flen, pending, nv):
    if pending[v] == 0:
        pending[v] = 1
        fifo[(fh + flen) % nv] = v
        flen += 1
    return flen


@kernel
def _apply(T, head, tail, deg, free, gv, g, z, d, ex, tet, fifo, pending, nv, ctr, scr):
    """Glue tetrahedron (gv, d) onto gate g; ``ex[k]`` = existing face (gv[k], gv[k+1], d).

    ``ctr`` holds [free count, bump, fifo head, fifo length, situation]; the situation is
    the number of cut-border spokes found among edges (gv[k], d) whose two faces were
    both new (non-manifold edges). Returns False if the cut-border is inconsistent.
    """
    nfree = ctr[0]
    bump = ctr[1]
    fh = ctr[2]
    flen = ctr[3]
    scr[:] = -1
    P = scr[0:3]
    Q = scr[3:6]
    R1 = scr[6:9]
    R2 = scr[9:12]
    X = scr[12:15]
    new = scr[15:18]
    fan_gate = scr[18:21]  # fans read before any row is freed and reused
    fan_spoke = scr[21:24]
    for k in range(3):
        fan_gate[k] = T[g, FAN + (z + k) % 3]
        P[k] = T[g, A0 + (z + k) % 3]
        if ex[k] >= 0 and ex[k] != P[k]:
            Q[k] = _across(T, ex[k], gv[k], gv[(k + 1) % 3])
    ctr[4] = 0
    for m in range(3):  # spoke (gv[m], d) between faces i = m and j = m - 1
        i = m
        j = (m + 2) % 3
        x = gv[m]
        fan_spoke[m] = 0
        if ex[i] >= 0:
            R1[m] = _across(T, ex[i], x, d)
            fan_spoke[m] = T[ex[i], FAN + _edge_slot(T, ex[i], x, d)]
        if ex[j] >= 0:
            R2[m] = _across(T, ex[j], x, d)
            fan_spoke[m] = T[ex[j], FAN + _edge_slot(T, ex[j], x, d)]
        if ex[i] < 0 and ex[j] < 0 and deg[d] > 0:
            X[m] = _edge_tri(T, head, deg, d, x)  # the direction of face i: d -> x
            if X[m] != -1:
                ctr[4] += 1
    # Remove the gate and the faces that become inner.
    for q in range(4):
        t = g if q == 0 else ex[q - 1]
        if t >= 0:
            _unlink(T, head, tail, deg, t)
            T[t, 0] = -1
            free[nfree] = t
            nfree += 1
    for k in range(3):
        if ex[k] < 0:
            t, nfree, bump = _alloc(T, free, nfree, bump)
            T[t, 0] = gv[k]
            T[t, 1] = gv[(k + 1) % 3]
            T[t, 2] = d
            T[t, A0] = -1
            T[t, A0 + 1] = -1
            T[t, A0 + 2] = -1
            T[t, INNER] = tet
            T[t, ZF] = 0
            T[t, FAN] = fan_gate[k] + 1
            T[t, FAN + 1] = fan_spoke[(k + 1) % 3] + 1
            T[t, FAN + 2] = fan_spoke[k] + 1
            _link(T, head, tail, deg, t)
            new[k] = t
    ok = True
    for k in range(3):  # gate edges
        u = gv[k]
        v = gv[(k + 1) % 3]
        if ex[k] < 0:
            ok &= _pair(T, new[k], P[k], u, v)
        elif ex[k] != P[k]:
            ok &= _pair(T, P[k], Q[k], u, v)
    for m in range(3):  # spokes
        i = m
        j = (m + 2) % 3
        x = gv[m]
        if ex[i] >= 0 and ex[j] >= 0:
            if R1[m] != ex[j]:
                ok &= _pair(T, R1[m], R2[m], x, d)
        elif ex[i] >= 0:
            ok &= _pair(T, new[j], R1[m], x, d)
        elif ex[j] >= 0:
            ok &= _pair(T, new[i], R2[m], x, d)
        elif X[m] == -1:
            ok &= _pair(T, new[i], new[j], x, d)
        else:  # split the outer region of an existing pair around a cut-border edge
            same = X[m] >= 0  # X has d -> x, as face i does: it pairs with face j
            xt = X[m] if same else -2 - X[m]
            y = _across(T, xt, x, d)
            if same:
                ok &= _pair(T, xt, new[j], x, d)
                ok &= _pair(T, new[i], y, x, d)
            else:
                ok &= _pair(T, xt, new[i], x, d)
                ok &= _pair(T, new[j], y, x, d)
    for k in range(3):
        flen = _push(gv[k], fifo, fh, flen, pending, nv)
    flen = _push(d, fifo, fh, flen, pending, nv)
    ctr[0] = nfree
    ctr[1] = bump
    ctr[3] = flen
    return ok


@kernel
def _parity(row, ref):
    """Parity of the permutation taking ``ref`` to ``row`` (both 4 distinct values)."""
    inv = 0
    for i in range(4):
        pi = 0
        for j in range(4):
            if row[i] == ref[j]:
                pi = j
        for k in range(i + 1, 4):
            for j in range(4):
                if row[k] == ref[j]:
                    inv += pi > j
    return inv & 1


@kernel
def _grow(T, tstamp, free, nfree):
    """Twice the triangle capacity (copied element-wise: no broadcasting code to compile)."""
    n = T.shape[0] * 2
    T2 = np.empty((n, TCOLS), dtype=np.int32)
    for i in range(T.shape[0]):
        for j in range(TCOLS):
            T2[i, j] = T[i, j]
    ts2 = np.zeros(n, dtype=np.int64)
    for i in range(tstamp.size):
        ts2[i] = tstamp[i]
    free2 = np.empty(n, dtype=np.int32)
    for i in range(nfree):
        free2[i] = free[i]
    return T2, ts2, np.empty(2 * n + 8, dtype=np.int32), free2


@kernel
def _near_class(T, head, deg, gv, x):
    """What connecting to x would do: 0 nothing known, 1 flip, 2 top or close, 3 border."""
    if x < 0:
        return 0
    c = 0
    for k in range(3):
        f = _find_face(T, head, deg, gv[k], gv[(k + 1) % 3], x)
        if f >= 0:
            if (T[f, ZF] & FLAG) != 0:
                return 3
            c += 1
    return min(c, 2)


@kernel
def _op_context(T, head, deg, g, z, gv, prev_kind, near):
    """Context of decision 0: the zero edge's fan, what connect 0 would close, the last kind.

    The neighbour across the zero edge gives connect 0's vertex x0; if that neighbour is a
    mesh border face, connect 0 means "border"; else count the other two gate edges that
    already form a cut-border face with x0 (flip, top, close). With 4 fan classes and 4
    previous kinds: 64 contexts. ``near`` receives x0 and its faces with the gate edges
    (x0 = -1 when not computed), so that connect 0 needs no search.
    """
    near[0] = -1
    f = T[g, FAN + z]
    fc = 0 if f <= 2 else (1 if f == 3 else (2 if f == 4 else 3))
    n = T[g, A0 + z]
    if n < 0 or (T[n, ZF] & FLAG) != 0:
        return 16 * fc + prev_kind
    j = _edge_slot(T, n, gv[0], gv[1])
    if j < 0:
        return 16 * fc + prev_kind
    x0 = T[n, (j + 2) % 3]
    near[0] = x0
    near[1] = n
    c = 1
    for k in range(1, 3):
        f = _find_face(T, head, deg, gv[k], gv[(k + 1) % 3], x0)
        near[1 + k] = f
        if f >= 0:
            c += 1
    return 16 * fc + 4 * c + prev_kind


@kernel
def _rest_context(T, head, deg, g, z, gv, tstamp, vstamp, stamp, queue, first, prev_kind):
    """Model of decision 1 (decisions 2..5 follow it), from what connect 1 and 2 would do.

    Also leaves the model in ``first[3]``.
    """
    _enumerate(T, g, z, np.int64(-1), np.int64(2), tstamp, vstamp, stamp, queue, first)
    c = 4 * _near_class(T, head, deg, gv, first[1]) + _near_class(T, head, deg, gv, first[2])
    c = 2 * c + (prev_kind == K_NEW)
    first[3] = M_OPR + 5 * c
    return first[3]


@kernel
def machine_kernel(
    dec,
    nt,
    nvu,
    ori_mode,
    tets_in,
    nbr,
    buf,
    cs,
    st,
    cost,
    tets_out,
    parent,
    gates,
    vcode,
    vorder,
    tet_order,
    stats,
    hist,
):
    """Run the cut-border machine over ``nt`` tetrahedra; return a status code.

    Encoder (``dec`` false): ``tets_in`` (input rows) and ``nbr`` (face neighbours) drive
    it; it writes ``buf`` and fills ``vcode`` (input -> coding index), ``vorder`` and
    ``tet_order``. Decoder: reads ``buf``. Both fill ``tets_out``, ``parent``, ``gates``.
    """
    nv = max(nvu, 1)
    cap = 1024
    T = np.empty((cap, TCOLS), dtype=np.int32)
    tstamp = np.zeros(cap, dtype=np.int64)
    queue = np.empty(2 * cap + 8, dtype=np.int32)
    free = np.empty(cap, dtype=np.int32)
    head = np.full(nv, -1, dtype=np.int32)
    tail = np.full(nv, -1, dtype=np.int32)
    deg = np.zeros(nv, dtype=np.int32)
    vstamp = np.zeros(nv, dtype=np.int64)
    pending = np.zeros(nv, dtype=np.uint8)
    fifo = np.empty(nv, dtype=np.int32)
    first = np.empty(4, dtype=np.int64)
    ex = np.empty(3, dtype=np.int64)
    near = np.empty(4, dtype=np.int64)
    gv = np.empty(3, dtype=np.int64)
    ws = np.empty(4, dtype=np.int64)
    ref4 = np.empty(4, dtype=np.int64)
    scr = np.empty(24, dtype=np.int64)
    ctr = np.zeros(5, dtype=np.int64)
    coded = np.zeros(nt if not dec else 0, dtype=np.uint8)
    NONE = np.int64(-1)  # typed, so that helpers compile once (not per literal)
    THREE = np.int64(3)
    stamp = 0
    nfree = 0
    bump = 0
    fh = 0
    flen = 0
    ntc = nt - nt  # a run-time zero: helpers taking it compile once, not for a literal 0
    nvc = 0
    scan = 0
    prev_kind = 0
    prev_ori = 0
    size = cs[3]
    while ntc < nt:
        if dec:
            if cs[2] > size + 4:
                return E_SHORT
        elif cs[2] + 256 > size:
            return E_OVERFLOW
        if bump + 4 > T.shape[0] and nfree < 4:
            T, tstamp, queue, free = _grow(T, tstamp, free, nfree)
        # --- the next gate: an unflagged triangle at the front vertex of the fifo
        g = -1
        while flen > 0:
            v = fifo[fh]
            s = head[v]
            while s >= 0:
                t = s // 3
                if (T[t, ZF] & FLAG) == 0:
                    g = t
                    break
                s = T[t, NX + s % 3]
            if g >= 0:
                break
            pending[v] = 0
            fh = (fh + 1) % nv
            flen -= 1
        if g < 0:
            # --- a new face-connected component: forget the old cut-border
            for t in range(bump):
                if T[t, 0] >= 0:
                    for k in range(3):
                        head[T[t, k]] = -1
                        tail[T[t, k]] = -1
                        deg[T[t, k]] = 0
            bump = 0
            nfree = 0
            stats[S_COMPONENTS] += 1
            cs[5] = C_START
            if not dec:
                while coded[scan]:
                    scan += 1
            for m in range(4):
                known = 0
                vi = 0
                if not dec:
                    vi = tets_in[scan, m]
                    known = np.int64(vcode[vi] >= 0)
                if nvc > 0:
                    known = _bit(cs, buf, st, cost, np.int64(M_KNOWN), known, dec)
                if known:
                    back = nvc - 1 - vcode[vi] if not dec else 0
                    back = _uint(cs, buf, st, cost, np.int64(M_FAR), back, dec)
                    w = nvc - 1 - back
                    if back < 0 or w < 0:
                        return E_SYMBOL
                    for mm in range(m):
                        if ws[mm] == w:
                            return E_SYMBOL
                else:
                    w = _new_vertex(vi, nvc, nvu, dec, vcode, vorder)
                    if w < 0:
                        return E_SYMBOL
                    nvc += 1
                ws[m] = w
            for m in range(4):
                tets_out[ntc, m] = ws[m]
            parent[ntc] = -1
            if not dec:
                tet_order[ntc] = scan
                coded[scan] = 1
            # outward faces of (w0, w1, w2, w3)
            for f in range(4):
                t, nfree, bump = _alloc(T, free, nfree, bump)
                if f == 0:
                    T[t, 0], T[t, 1], T[t, 2] = ws[1], ws[2], ws[3]
                elif f == 1:
                    T[t, 0], T[t, 1], T[t, 2] = ws[0], ws[3], ws[2]
                elif f == 2:
                    T[t, 0], T[t, 1], T[t, 2] = ws[0], ws[1], ws[3]
                else:
                    T[t, 0], T[t, 1], T[t, 2] = ws[0], ws[2], ws[1]
                T[t, INNER] = ntc
                T[t, ZF] = 0
                T[t, FAN] = 1
                T[t, FAN + 1] = 1
                T[t, FAN + 2] = 1
                _link(T, head, tail, deg, t)
            for f1 in range(4):
                for f2 in range(f1 + 1, 4):
                    # faces f1 and f2 share the edge of the two vertices other than f1, f2
                    u = NONE
                    for m in range(4):
                        if m != f1 and m != f2:
                            if u < 0:
                                u = ws[m]
                            else:
                                _pair(T, np.int64(f1), np.int64(f2), u, ws[m])
            for m in range(4):
                flen = _push(ws[m], fifo, fh, flen, pending, nv)
            ntc += 1
            continue
        # --- an operation at gate g
        z = T[g, ZF] & 3
        for k in range(3):
            gv[k] = T[g, (z + k) % 3]
        stamp += 2  # one numbering for the operation, one for its context
        kind = K_CONN
        idx = 0
        d = -1
        d_in = -1
        t_out = -1
        ex[0] = -1
        ex[1] = -1
        ex[2] = -1
        ctx = M_OP + _op_context(T, head, deg, g, z, gv, prev_kind, near)
        if not dec:
            # the tetrahedron across the gate, from the mesh
            t_in = tet_order[T[g, INNER]]
            lf = 0
            for m in range(4):
                c = vcode[tets_in[t_in, m]]
                if c != gv[0] and c != gv[1] and c != gv[2]:
                    lf = m
            t_out = nbr[t_in, lf]
            if t_out < 0:
                kind = K_BORDER
                _enumerate(T, g, z, NONE, THREE - 1, tstamp, vstamp, stamp, queue, first)
                for j in range(3):
                    x = first[j]
                    if x < 0:
                        break
                    hit = False
                    for k in range(3):
                        f = _find_face(T, head, deg, gv[k], gv[(k + 1) % 3], x)
                        if f >= 0 and (T[f, ZF] & FLAG) != 0:
                            hit = True
                    if hit:
                        kind = K_CONN
                        idx = j
                        d = x
                        break
            else:
                for m in range(4):
                    y = tets_in[t_out, m]
                    c = vcode[y]
                    if c < 0 or (c != gv[0] and c != gv[1] and c != gv[2]):
                        d_in = y
                d = vcode[d_in]
                if d < 0:
                    kind = K_NEW
                elif deg[d] == 0:
                    kind = K_FAR
                elif d == near[0]:
                    idx = 0
                else:
                    r = _enumerate(T, g, z, d, NONE, tstamp, vstamp, stamp, queue, first)
                    if r >= 0:
                        idx = r
                    else:
                        kind = K_FAR
        # --- the operation symbol
        cs[5] = C_OP
        c0 = cost[C_OP] + cost[C_IDX] + cost[C_FAR]
        if _bit(cs, buf, st, cost, ctx, np.int64(kind == K_CONN and idx == 0), dec):
            kind = K_CONN
            idx = 0
        elif _bit(
            cs,
            buf,
            st,
            cost,
            _rest_context(
                T, head, deg, g, z, gv, tstamp, vstamp, stamp + 1, queue, first, prev_kind
            ),
            np.int64(kind == K_NEW),
            dec,
        ):
            kind = K_NEW
        elif _bit(cs, buf, st, cost, first[3] + 1, np.int64(kind == K_CONN and idx == 1), dec):
            kind = K_CONN
            idx = 1
        elif _bit(cs, buf, st, cost, first[3] + 2, np.int64(kind == K_CONN and idx == 2), dec):
            kind = K_CONN
            idx = 2
        elif _bit(cs, buf, st, cost, first[3] + 3, np.int64(kind == K_CONN), dec):
            kind = K_CONN
            cs[5] = C_IDX
            idx = 3 + _uint(cs, buf, st, cost, np.int64(M_IDX), idx - 3, dec)
            if idx < 3:
                return E_SYMBOL
        elif _bit(cs, buf, st, cost, first[3] + 4, np.int64(kind == K_FAR), dec):
            kind = K_FAR
            cs[5] = C_FAR
            back = nvc - 1 - d if not dec else 0
            back = _uint(cs, buf, st, cost, np.int64(M_FAR), back, dec)
            if back < 0 or back >= nvc:
                return E_SYMBOL
            d = nvc - 1 - back
        else:
            kind = K_BORDER
        stats[S_OPS] += 1
        hist_i = idx + 3 if kind == K_CONN else (0 if kind == K_BORDER else kind)
        if hist_i < hist.size:
            hist[hist_i] += 1
        prev_kind = kind
        shortcut = kind == K_CONN and idx == 0 and near[0] >= 0  # d = x0, faces known
        if dec and kind == K_CONN:
            if shortcut:
                d = near[0]
            else:
                r = _enumerate(T, g, z, NONE, idx, tstamp, vstamp, stamp, queue, first)
                if r > -2:
                    return E_SYMBOL
                d = -2 - r
        border = kind == K_BORDER
        if kind == K_CONN or kind == K_FAR:
            if d == gv[0] or d == gv[1] or d == gv[2]:
                return E_SYMBOL
            if deg[d] > 0:
                for k in range(3):
                    f = (
                        near[1 + k]
                        if shortcut
                        else _find_face(T, head, deg, gv[k], gv[(k + 1) % 3], d)
                    )
                    ex[k] = f
                    if f >= 0 and (T[f, ZF] & FLAG) != 0:
                        border = True
            if border:
                if kind == K_FAR:
                    return E_SYMBOL
                stats[S_BORDER_CONN] += 1
        if border:
            if kind == K_BORDER:
                stats[S_DELTA] += 1
            cost[C_BORDER] += cost[C_OP] + cost[C_IDX] + cost[C_FAR] - c0
            T[g, ZF] |= FLAG
            continue
        # --- a tetrahedron: the new vertex, its orientation, the update
        if kind == K_NEW:
            d = _new_vertex(d_in, nvc, nvu, dec, vcode, vorder)
            if d < 0:
                return E_SYMBOL
            nvc += 1
            gates[d, 0] = gv[0]
            gates[d, 1] = gv[1]
            gates[d, 2] = gv[2]
            stats[S_NEW] += 1
        elif kind == K_FAR:
            stats[S_FAR] += 1
        else:
            stats[S_CONN] += 1
        flip = 0
        if ori_mode:
            cs[5] = C_ORI
            if not dec:
                for m in range(4):
                    ws[m] = vcode[tets_in[t_out, m]]
                ref4[0] = gv[0]
                ref4[1] = gv[1]
                ref4[2] = gv[2]
                ref4[3] = d
                flip = _parity(ws, ref4)
            flip = _bit(cs, buf, st, cost, M_ORI + prev_ori, flip, dec)
            prev_ori = flip
            stats[S_ORI] += flip
        if flip:
            tets_out[ntc, 0] = gv[1]
            tets_out[ntc, 1] = gv[0]
        else:
            tets_out[ntc, 0] = gv[0]
            tets_out[ntc, 1] = gv[1]
        tets_out[ntc, 2] = gv[2]
        tets_out[ntc, 3] = d
        parent[ntc] = T[g, INNER]
        if not dec:
            tet_order[ntc] = t_out
            coded[t_out] = 1
        npresent = (ex[0] >= 0) + (ex[1] >= 0) + (ex[2] >= 0)
        on_border = deg[d] > 0
        ctr[0] = nfree
        ctr[1] = bump
        ctr[2] = fh
        ctr[3] = flen
        ok = _apply(T, head, tail, deg, free, gv, g, z, d, ex, ntc, fifo, pending, nv, ctr, scr)
        nfree = ctr[0]
        bump = ctr[1]
        flen = ctr[3]
        if not ok:
            return E_SYMBOL
        if kind == K_FAR and not on_border:
            stats[S_REVISIT] += 1
        elif npresent == 1:
            stats[S_FLIP + (ctr[4] > 0)] += 1
        elif npresent == 2:
            stats[S_TOP] += 1
        elif npresent == 3:
            stats[S_CLOSE] += 1
        elif on_border:
            stats[S_JOIN0 + min(ctr[4], 3)] += 1
        ntc += 1
    if nvc != nvu:
        return E_SYMBOL
    if dec and cs[2] > size + 4:
        return E_SHORT
    if not dec:
        for _ in range(4):  # the final low pins the interval
            buf[cs[2]] = cs[0] >> 24
            cs[2] += 1
            cs[0] = (cs[0] << 8) & 0xFFFFFFFF
    return OK


@kernel
def _match_face(tets, nbr, info, fi, fj):
    """Pair faces fi = 4 t + l and fj (same vertex set); 0 or the error code."""
    t, lf = fi // 4, fi % 4
    s, m = fj // 4, fj % 4
    if nbr[s, m] >= 0 or nbr[t, lf] >= 0:
        return 1 + t
    if tets[s, m] == tets[t, lf]:
        return -(1 + t)
    nbr[s, m] = t
    nbr[t, lf] = s
    return 0


@kernel
def coding_adjacency_kernel(tets, nbr, tets_out, tet_order, vcode, out):
    """The face neighbours ``nbr`` (input rows and vertex places) in coding order: for
    coded tet j and place p, the coded tet across the face opposite ``tets_out[j, p]``."""
    nt = tets_out.shape[0]
    coded = np.empty(nt, np.int64)
    for j in range(nt):
        coded[tet_order[j]] = j
    for j in range(nt):
        t = tet_order[j]
        for p in range(4):
            out[j, p] = -1
            for m in range(4):
                if vcode[tets[t, m]] == tets_out[j, p]:
                    n = nbr[t, m]
                    out[j, p] = coded[n] if n >= 0 else -1
                    break


@kernel
def face_neighbours_kernel(tets, nv, nbr, info):
    """Fill nbr[t, l] = tetrahedron across the face opposite vertex l (-1: mesh border).

    Faces come bucketed by their smallest vertex (:func:`..mesh.bucket_faces`) and are
    matched within a bucket. Returns 0, or 1 + t for a face shared by more than two
    tetrahedra (at tet t), or -(1 + t) for a tetrahedron that repeats another one's
    vertex set. ``info[0]`` counts inner faces whose two tetrahedra are oppositely
    oriented.
    """
    nbr[:] = -1
    start, key, fid = bucket_faces(tets, nv)
    low = PARITY - 1
    for v in range(nv):
        lo = start[v]
        hi = start[v + 1]
        if hi - lo > HUB:  # sorted: equal faces are neighbours
            for i in range(lo + 1, hi):
                if key[i] == key[i - 1]:
                    if i + 1 < hi and key[i + 1] == key[i]:
                        return 1 + (fid[i + 1] & low) // 4
                    r = _match_face(tets, nbr, info, fid[i] & low, fid[i - 1] & low)
                    if r != 0:
                        return r
                    info[0] += (fid[i] >> 62) == (fid[i - 1] >> 62)
            continue
        for i in range(lo, hi):
            for j in range(lo, i):
                if key[i] == key[j]:
                    r = _match_face(tets, nbr, info, fid[i] & low, fid[j] & low)
                    if r != 0:
                        return r
                    info[0] += (fid[i] >> 62) == (fid[j] >> 62)
    return 0
