"""Tetrahedral mesh connectivity: the cut-border machine (thesis §3.3, digest §10).

The mesh is grown one face-connected component at a time from its first tetrahedron. A
cut-border (the triangle surface between coded and uncoded tetrahedra) is kept; at each
step a gate triangle of it is taken from the vertex at the front of a FIFO and one
operation says what lies across the gate:

``border``
    nothing (a face of the mesh border);
``new vertex``
    a tetrahedron whose fourth vertex has not been seen yet;
``connect i``
    a tetrahedron whose fourth vertex is cut-border vertex number ``i`` of a
    breadth-first numbering from the gate's zero edge (most are 0: a "flip");
``far``
    a tetrahedron whose fourth vertex was seen but is not reachable that way
    (components touching at a vertex or an edge), given by its coding index.

Operations are coded with an adaptive binary range coder (the coder of
:mod:`volpack.entropy.arith`) as a short decision tree whose probabilities start from the
thesis's average frequencies. Orientation follows from the oriented gate; only the
exceptions are coded. The stream layout is ``formats/tetra-connectivity-1.md``.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import dataclass

import numpy as np

from ..errors import FormatError, LimitError

MAGIC = b"VTC1"
DEFAULT_MAX_TETS = 1 << 27
# Each tetrahedron costs at least one adaptive decision, and a model never gets more
# likely than 4033/4096 (0.022 bits): a stream of n bytes holds < 370 n tetrahedra.
TETS_PER_BYTE = 800

STAT_NAMES = (
    "ops",
    "border_delta",
    "border_connect",
    "new_vertex",
    "far",
    "connect",
    "flip",
    "nm_flip",
    "top",
    "close",
    "join",
    "join_1",
    "join_2",
    "join_3",
    "revisit",
    "components",
    "orientation_exceptions",
)


@dataclass(frozen=True)
class Traversal:
    """The coding order of a mesh, as the decoder reproduces it.

    ``tets``: int32 (nt, 4), tetrahedra in coding order, vertices numbered in coding order.
    ``vertex_order[k]``: input index of the k-th coded vertex (decoder: arange).
    ``tet_order[j]``: input row of the j-th coded tetrahedron (decoder: arange).
    ``gates[k]``: the gate (a, b, c) across which vertex k was introduced, all < k, zero
    edge first (a -> b) and oriented towards the new vertex: (a, b, c, k) has the
    orientation of the gate's new tetrahedron. -1 for vertices without a gate.
    ``tet_parent[j]``: coded tetrahedron across the gate tetrahedron j was added at, or -1.
    ``adjacency`` (encoder only, else None): int64 (nt, 4), the coded tetrahedron across
    the face opposite vertex i of coded tetrahedron j, or -1 (what
    :func:`.mesh.face_adjacency` of ``tets`` gives, from the neighbours the encoder
    found anyway).
    """

    tets: np.ndarray
    vertex_order: np.ndarray
    tet_order: np.ndarray
    gates: np.ndarray
    tet_parent: np.ndarray
    adjacency: np.ndarray | None = None


def _kernels():
    from . import _cutborder_kernels as k

    return k


def _varint(n: int) -> bytes:
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        out.append(b | (0x80 if n else 0))
        if not n:
            return bytes(out)


def _read_varint(data: bytes, pos: int, what: str) -> tuple[int, int]:
    n = 0
    for shift in range(0, 64, 7):
        if pos >= len(data):
            raise FormatError(f"tetra connectivity: stream ends inside the {what}")
        b = data[pos]
        pos += 1
        n |= (b & 0x7F) << shift
        if not b & 0x80:
            return n, pos
    raise FormatError(f"tetra connectivity: the {what} is longer than 9 bytes")


def _validate(tets, n_vertices: int) -> tuple[np.ndarray, int]:
    a = np.asarray(tets)
    if a.size == 0 and a.ndim <= 2:
        a = a.reshape(0, 4).astype(np.int32)  # [] or an empty array: no tetrahedra
    if a.ndim != 2 or a.shape[1] != 4:
        raise FormatError(f"expected tetrahedra as an (n, 4) array, found shape {a.shape}")
    if a.size and a.dtype.kind not in "iu":
        raise FormatError(f"expected integer vertex indices, found dtype {a.dtype}")
    nv = int(n_vertices)
    if nv < 0 or nv >= 2**31:
        raise FormatError(f"expected 0 <= n_vertices < 2**31, found {nv}")
    if a.size:
        lo, hi = int(a.min()), int(a.max())
        if lo < 0 or hi >= nv:
            bad = lo if lo < 0 else hi
            raise FormatError(f"expected vertex indices in [0, {nv}), found {bad}")
    a = np.ascontiguousarray(a, dtype=np.int32)
    if a.size:
        s = np.sort(a, axis=1)
        rep = np.flatnonzero((s[:, 1:] == s[:, :-1]).any(axis=1))
        if rep.size:
            r = int(rep[0])
            raise FormatError(
                f"expected four distinct vertices per tetrahedron, found {a[r].tolist()} at row {r}"
            )
    return a, nv


def _neighbours(a: np.ndarray) -> tuple[np.ndarray, int]:
    nbr = np.empty(a.shape, dtype=np.int32)
    info = np.zeros(1, dtype=np.int64)
    r = int(_kernels().face_neighbours_kernel(a, int(a.max()) + 1 if a.size else 0, nbr, info))
    if r > 0:
        raise FormatError(
            f"expected each face in at most two tetrahedra, found a third at row {r - 1}"
        )
    if r < 0:
        raise FormatError(
            f"expected distinct tetrahedra, found row {-r - 1} repeating an earlier one"
        )
    return nbr, int(info[0])


def _run_encoder(a: np.ndarray, nv: int, measure: bool, keep_orientation: bool = True):
    k = _kernels()
    nt = a.shape[0]
    nbr, inconsistent = _neighbours(a)
    used = np.zeros(nv, dtype=bool)
    used[a.reshape(-1)] = True
    nvu = int(used.sum())
    ori_mode = 1 if inconsistent and keep_orientation else 0
    for per_tet in (2, 16, 96):
        buf = np.empty(nt * per_tet + 4096, dtype=np.uint8)
        cs = np.zeros(8, dtype=np.int64)
        cs[1] = 0xFFFFFFFF
        cs[2] = 1
        cs[3] = buf.size
        cs[4] = 1 if measure else 0
        buf[0] = 0  # takes the carry of the first bits
        cost = np.zeros(k.N_COST, dtype=np.float64)
        tets_out = np.empty((nt, 4), dtype=np.int32)
        parent = np.empty(nt, dtype=np.int32)
        gates = np.full((nv, 3), -1, dtype=np.int32)
        vcode = np.full(nv, -1, dtype=np.int64)
        vorder = np.empty(nv, dtype=np.int64)
        tet_order = np.empty(nt, dtype=np.int64)
        stats = np.zeros(k.N_STATS, dtype=np.int64)
        hist = np.zeros(k.MAX_INDEX + 4, dtype=np.int64)
        status = k.machine_kernel(
            False, nt, nvu, ori_mode, a, nbr, buf, cs, k.initial_models(), cost,
            tets_out, parent, gates, vcode, vorder, tet_order, stats, hist,
        )  # fmt: skip
        if status == k.OK:
            break
        if status != k.E_OVERFLOW:
            raise AssertionError(f"cut-border encoder failed with status {status}")
    else:  # pragma: no cover - the last buffer is the worst case
        raise AssertionError("cut-border encoder overflowed its worst-case buffer")
    payload = buf[: cs[2]].tobytes() if nt else b""
    vorder[nvu:] = np.flatnonzero(~used)
    counts = MAGIC + _varint(nt) + _varint(nv) + _varint(nvu) + bytes([ori_mode])
    header = counts + zlib.crc32(payload, zlib.crc32(counts)).to_bytes(4, "little")
    adj = np.empty((nt, 4), dtype=np.int64)
    k.coding_adjacency_kernel(a, nbr, tets_out, tet_order, vcode, adj)
    trav = Traversal(tets_out, vorder, tet_order, gates, parent, adj)
    return header + payload, trav, stats, hist, cost, nbr


def encode_connectivity(
    tets: np.ndarray, n_vertices: int, *, keep_orientation: bool = True
) -> tuple[bytes, Traversal]:
    """Code the connectivity of a tetrahedral mesh; return the stream and its traversal.

    ``tets`` is an (nt, 4) integer array of vertex indices in ``[0, n_vertices)``. The
    stream reproduces the tetrahedra up to a renumbering of vertices and tetrahedra (given
    by the returned :class:`Traversal`), each with the orientation of its input row: a
    tetrahedron oriented against its face neighbours costs a flag. With
    ``keep_orientation=False`` no flags are coded and every tetrahedron comes back
    oriented like the first one of its component (rows whose source has no consistent
    orientation, e.g. sorted vertex indices, then save up to a bit per tetrahedron).
    """
    a, nv = _validate(tets, n_vertices)
    data, trav, *_ = _run_encoder(a, nv, measure=False, keep_orientation=keep_orientation)
    return data, trav


def decode_connectivity(data: bytes, *, max_tets: int = DEFAULT_MAX_TETS) -> Traversal:
    """Decode a stream of :func:`encode_connectivity` (vertices in coding order).

    ``max_tets`` bounds what a stream may declare (tetrahedra, and unreferenced vertices)
    before anything is allocated.
    """
    data = bytes(data)
    if data[:4] != MAGIC:
        raise FormatError(f"expected a tetra connectivity stream ({MAGIC!r}), found {data[:4]!r}")
    nt, pos = _read_varint(data, 4, "tetrahedron count")
    nv, pos = _read_varint(data, pos, "vertex count")
    nvu, pos = _read_varint(data, pos, "used vertex count")
    if pos + 5 > len(data):
        raise FormatError("tetra connectivity: stream ends inside the header")
    ori_mode = data[pos]
    crc = int.from_bytes(data[pos + 1 : pos + 5], "little")
    payload = data[pos + 5 :]
    if ori_mode > 1:
        raise FormatError(f"tetra connectivity: expected orientation mode 0 or 1, found {ori_mode}")
    if nt > max_tets:
        raise LimitError(f"tetra connectivity: {nt} tetrahedra exceed the limit of {max_tets}")
    if nt > TETS_PER_BYTE * len(payload) + (0 if nt == 0 else -TETS_PER_BYTE * 5 + 64):
        raise LimitError(
            f"tetra connectivity: {nt} tetrahedra cannot fit in {len(payload)} payload bytes"
        )
    if nvu > 4 * nt or (nt and nvu < 4) or nvu > nv or nv - nvu > max_tets:
        raise FormatError(
            f"tetra connectivity: inconsistent counts ({nt} tetrahedra, {nvu} used of "
            f"{nv} vertices)"
        )
    if zlib.crc32(payload, zlib.crc32(data[: pos + 1])) != crc:
        raise FormatError("tetra connectivity: payload checksum mismatch (corrupt stream)")
    return _decode_payload(payload, nt, nv, nvu, ori_mode)


def _decode_payload(payload: bytes, nt: int, nv: int, nvu: int, ori_mode: int) -> Traversal:
    k = _kernels()
    tets = np.empty((nt, 4), dtype=np.int32)
    parent = np.empty(nt, dtype=np.int32)
    gates = np.full((nv, 3), -1, dtype=np.int32)
    if nt:
        buf = np.frombuffer(bytearray(payload), dtype=np.uint8)
        cs = np.zeros(8, dtype=np.int64)
        cs[1] = 0xFFFFFFFF
        pos = 1  # the encoder's first byte is always zero
        for _ in range(4):
            cs[0] = (cs[0] << 8) | (int(buf[pos]) if pos < buf.size else 0)
            pos += 1
        cs[2] = pos
        cs[3] = buf.size
        dummy = np.zeros((0, 4), dtype=np.int32)
        none = np.zeros(0, dtype=np.int64)
        status = k.machine_kernel(
            True, nt, nvu, ori_mode, dummy, dummy, buf, cs, k.initial_models(), np.zeros(k.N_COST),
            tets, parent, gates, none, none, none,
            np.zeros(k.N_STATS, dtype=np.int64), np.zeros(0, dtype=np.int64),
        )  # fmt: skip
        if status != k.OK:
            why = {k.E_SHORT: "the stream ends early", k.E_SYMBOL: "an impossible operation"}
            raise FormatError(f"corrupt tetra connectivity: {why.get(status, status)}")
    return Traversal(
        tets, np.arange(nv, dtype=np.int64), np.arange(nt, dtype=np.int64), gates, parent
    )


def _entropy_bits(counts: np.ndarray) -> float:
    c = counts[counts > 0].astype(np.float64)
    n = c.sum()
    return float(-(c * np.log2(c / n)).sum()) if n else 0.0


def connectivity_stats(tets: np.ndarray, n_vertices: int, *, keep_orientation: bool = True) -> dict:
    """The thesis's Tables 3.5-3.8 quantities for one mesh (connectivity part).

    Counts v, e, f, b, t; operation frequencies (``nu_*``, over the coded operations);
    situations (flip, top, close, joins, ...); bits per tetrahedron and per vertex from the
    order-0 entropy of the operations (``entropy_*``) and from the adaptive coder
    (``adaptive_*``, the stream size); bits per border face; baselines.
    """
    a, nv = _validate(tets, n_vertices)
    data, trav, stats, hist, cost, nbr = _run_encoder(a, nv, True, keep_orientation)
    k = _kernels()
    nt = a.shape[0]
    v = int(np.unique(a).size) if nt else 0
    b = int((nbr < 0).sum())
    f = 2 * nt + b // 2
    if nt:
        p, q = a[:, [0, 0, 0, 1, 1, 2]], a[:, [1, 2, 3, 2, 3, 3]]  # the six edges
        lo = np.minimum(p, q).reshape(-1).astype(np.int64)
        hi = np.maximum(p, q).reshape(-1).astype(np.int64)
        e = int(np.unique(lo * (nv + 1) + hi).size)
    else:
        e = 0
    ops = int(stats[k.S_OPS])
    named = {name: int(stats[i]) for i, name in enumerate(STAT_NAMES)}
    coded_border = named["border_delta"] + named["border_connect"]
    bits = 8.0 * len(data)
    ent = _entropy_bits(hist)
    nm = sum(named[n] for n in ("nm_flip", "join", "join_1", "join_2", "join_3", "revisit"))
    tet_ops = max(ops - coded_border, 1)
    out = {
        "v": v,
        "e": e,
        "f": f,
        "b": b,
        "t": nt,
        "chi": v - e + f - nt,
        "stream_bytes": len(data),
        "ops_coded": ops,
        "t_minus_1_plus_b": nt - 1 + b if nt else 0,
        **named,
        "nu_border": hist[0] / ops if ops else 0.0,
        "nu_new": hist[1] / ops if ops else 0.0,
        "nu_far": hist[2] / ops if ops else 0.0,
        "nu_connect0": hist[3] / ops if ops else 0.0,
        "nu_connect1": hist[4] / ops if ops else 0.0,
        "nu_connect2": hist[5] / ops if ops else 0.0,
        "nu_connect_gt2": hist[6:].sum() / ops if ops else 0.0,
        "nu_nonmanifold": nm / tet_ops,
        "entropy_bits": ent,
        "entropy_bits_per_tet": ent / nt if nt else 0.0,
        "entropy_bits_per_vertex": ent / v if v else 0.0,
        "adaptive_bits_per_tet": bits / nt if nt else 0.0,
        "adaptive_bits_per_vertex": bits / v if v else 0.0,
        "model_bits_ops": float(cost[k.C_OP]),
        "model_bits_connect_index": float(cost[k.C_IDX]),
        "model_bits_far_index": float(cost[k.C_FAR]),
        "model_bits_orientation": float(cost[k.C_ORI]),
        "model_bits_component_start": float(cost[k.C_START]),
        "border_bits_per_coded_border_face": float(cost[k.C_BORDER]) / coded_border
        if coded_border
        else 0.0,
        "border_bits_per_border_face": float(cost[k.C_BORDER]) / b if b else 0.0,
        "std_bits": 4.0 * nt * math.ceil(math.log2(max(v, 2))),
        "grow_fold_bits": 7.0 * nt,
    }
    out["std_over_adaptive"] = out["std_bits"] / bits if nt else 0.0
    out["traversal_components"] = int((trav.tet_parent < 0).sum())
    return out
