"""The tetrahedral mesh model: vertices, tetrahedra, point and cell data, and its checks.

A :class:`TetMesh` holds vertex coordinates ``(nv, 3)`` (float32 or float64, kept as
given), tetrahedra ``(nt, 4)`` of vertex indices, and per-vertex and per-tet data arrays
(material ids, fields; scalars, vectors and tensors). :func:`validate` refuses what is
not a tetrahedral mesh at all (bad shapes, indices out of range, a vertex repeated in a
tet); :func:`report` counts what is legal but worth knowing (zero-volume and inverted
tets, unreferenced and duplicate vertices, border faces, face-connected components,
non-manifold faces, edges and vertices, the Euler characteristic; seed-004 §10.1).

Face adjacency is found by bucketing: each of the ``4 nt`` faces becomes a sorted vertex
triple in the bucket of its smallest vertex (:func:`bucket_faces`, which the cut-border
coder shares), and a face met twice in a bucket links its two tets.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._jit import kernel
from ..errors import FormatError

__all__ = [
    "FACES",
    "TetMesh",
    "components",
    "edge_keys",
    "face_adjacency",
    "report",
    "signed_volumes",
    "validate",
]

# Face i of a tet is the one opposite its vertex i, ordered so that (face, vertex i) has
# the tet's orientation: in a positive tet the face's normal (right hand) points inwards.
FACES = np.array([[1, 3, 2], [0, 2, 3], [0, 3, 1], [0, 1, 2]], dtype=np.int64)
_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], dtype=np.int64)


@dataclass
class TetMesh:
    """A tetrahedral mesh.

    Parameters
    ----------
    points : ndarray of shape (nv, 3), float32 or float64
        Vertex coordinates (x, y, z).
    tets : ndarray of shape (nt, 4), integer
        Vertex indices of each tetrahedron (stored as int64).
    point_data, cell_data : dict of str to ndarray
        Arrays with ``nv`` (``nt``) rows; any trailing shape (vectors, tensors).
    """

    points: np.ndarray
    tets: np.ndarray
    point_data: dict[str, np.ndarray] = field(default_factory=dict)
    cell_data: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        pts = np.asarray(self.points)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise FormatError(f"expected vertex coordinates of shape (nv, 3), found {pts.shape}")
        if pts.dtype not in (np.float32, np.float64):
            if pts.dtype.kind not in "iuf":
                raise FormatError(f"expected float coordinates, found dtype {pts.dtype}")
            pts = pts.astype(np.float64)
        self.points = np.ascontiguousarray(pts.astype(pts.dtype.newbyteorder("=")))
        tets = np.asarray(self.tets)
        if tets.size == 0:
            tets = tets.reshape(0, 4)
        if tets.ndim != 2 or tets.shape[1] != 4:
            raise FormatError(f"expected tetrahedra of shape (nt, 4), found {tets.shape}")
        if tets.dtype.kind not in "iu":
            raise FormatError(f"expected integer vertex indices, found dtype {tets.dtype}")
        self.tets = np.ascontiguousarray(tets, dtype=np.int64)
        self.point_data = _check_data(self.point_data, len(self.points), "point")
        self.cell_data = _check_data(self.cell_data, len(self.tets), "cell")

    @property
    def n_vertices(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_tets(self) -> int:
        return int(self.tets.shape[0])


def _check_data(data: dict, n: int, what: str) -> dict[str, np.ndarray]:
    out = {}
    for name, arr in (data or {}).items():
        a = np.asarray(arr)
        if a.ndim == 0 or a.shape[0] != n:
            raise FormatError(f"{what} data {name!r}: expected {n} rows, found shape {a.shape}")
        if a.dtype.kind not in "biuf":
            raise FormatError(f"{what} data {name!r}: expected numbers, found dtype {a.dtype}")
        out[str(name)] = np.ascontiguousarray(a.astype(a.dtype.newbyteorder("=")))
    return out


def validate(mesh: TetMesh) -> None:
    """Raise :class:`FormatError` when ``mesh`` is not a tetrahedral mesh.

    Indices must lie in ``0..nv-1`` and the four vertices of a tet must differ. Zero
    volume, inversion, duplicate or unreferenced vertices are legal (see :func:`report`).
    """
    t = mesh.tets
    if t.size == 0:
        return
    lo, hi = int(t.min()), int(t.max())
    if lo < 0 or hi >= mesh.n_vertices:
        bad = int(np.nonzero((t < 0) | (t >= mesh.n_vertices))[0][0])
        raise FormatError(
            f"tet {bad} has vertex indices {t[bad].tolist()}: expected 0..{mesh.n_vertices - 1}"
        )
    s = np.sort(t, axis=1)
    rep = np.nonzero((s[:, 1:] == s[:, :-1]).any(axis=1))[0]
    if rep.size:
        raise FormatError(
            f"{rep.size} tets repeat a vertex (first: tet {int(rep[0])} = "
            f"{t[rep[0]].tolist()}): expected four different vertices per tet"
        )


def signed_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """Return six times the signed volume of each tet (positive: right-handed)."""
    p = np.asarray(points, dtype=np.float64)
    a = p[tets[:, 0]]
    return np.einsum("ij,ij->i", np.cross(p[tets[:, 1]] - a, p[tets[:, 2]] - a), p[tets[:, 3]] - a)


def face_adjacency(tets: np.ndarray) -> tuple[np.ndarray, int]:
    """Return the tet across each face (``(nt, 4)``, -1 on the border) and the number of
    faces met more than twice (non-manifold; their third and later tets stay unlinked).

    Face ``i`` is the face opposite vertex ``i``. Faces are bucketed by their smallest
    vertex and matched inside their bucket.
    """
    t = np.ascontiguousarray(tets, dtype=np.int64).reshape(-1, 4)
    adj = np.full((len(t), 4), -1, dtype=np.int64)
    if len(t) == 0:
        return adj, 0
    extra = int(_face_adjacency_kernel(t, adj, int(t.max()) + 1))
    return adj, extra


def components(adj: np.ndarray) -> np.ndarray:
    """Return the face-connected component label (0, 1, ...) of each tet."""
    return _components_kernel(np.ascontiguousarray(adj, dtype=np.int64))


def edge_keys(tets: np.ndarray, nv: int) -> np.ndarray:
    """Return the key ``lo * nv + hi`` of each of the ``6 nt`` tet edges (with repeats)."""
    e = np.sort(tets[:, _EDGES], axis=2).reshape(-1, 2)
    return e[:, 0] * np.int64(nv) + e[:, 1]


def report(mesh: TetMesh) -> dict:
    """Count what a mesh holds and what is unusual about it (plain JSON types).

    Keys: ``vertices``, ``tets``, ``edges``, ``faces``, ``border_faces``, ``euler``
    (v - e + f - t), ``components`` (face-connected), ``zero_volume``, ``inverted``
    (orientation against the majority), ``negative_volume``, ``unreferenced_vertices``,
    ``duplicate_vertices`` (same coordinates as an earlier vertex),
    ``nonmanifold_faces`` / ``_edges`` / ``_vertices``, ``border_vertices``, and the
    point and cell data fields.
    """
    validate(mesh)
    nv, nt = mesh.n_vertices, mesh.n_tets
    t = mesh.tets
    out: dict = {"vertices": nv, "tets": nt}
    used = np.zeros(nv, dtype=bool)
    used[t.reshape(-1)] = True
    out["unreferenced_vertices"] = int(nv - used.sum())
    out["duplicate_vertices"] = int(nv - len(np.unique(mesh.points, axis=0))) if nv else 0
    if nt:
        adj, nm_faces = face_adjacency(t)
        vol = signed_volumes(mesh.points, t)
        neg = int((vol < 0).sum())
        pos = int((vol > 0).sum())
        ekeys = np.unique(edge_keys(t, nv))
        border = adj < 0
        nfaces = int((4 * nt + border.sum()) // 2)
        bverts = np.unique(t[:, FACES][border].reshape(-1)) if border.any() else np.empty(0)
        nm_edges = _nonmanifold_edges(t, nv)
        groups = _vertex_fans_kernel(t, adj, nv)
        out.update(
            edges=int(ekeys.size),
            faces=nfaces,
            border_faces=int(border.sum()),
            border_vertices=int(bverts.size),
            euler=int(nv - out["unreferenced_vertices"] - ekeys.size + nfaces - nt),
            components=int(components(adj).max() + 1),
            zero_volume=int(nt - neg - pos),
            negative_volume=neg,
            inverted=min(neg, pos),
            nonmanifold_faces=nm_faces,
            nonmanifold_edges=nm_edges,
            nonmanifold_vertices=int((groups > 1).sum()),
        )
    else:
        out.update(
            edges=0, faces=0, border_faces=0, border_vertices=0, euler=0, components=0,
            zero_volume=0, negative_volume=0, inverted=0, nonmanifold_faces=0,
            nonmanifold_edges=0, nonmanifold_vertices=0,
        )  # fmt: skip
    out["point_data"] = {k: _describe(v) for k, v in mesh.point_data.items()}
    out["cell_data"] = {k: _describe(v) for k, v in mesh.cell_data.items()}
    return out


def _describe(a: np.ndarray) -> dict:
    return {"dtype": a.dtype.str, "shape": list(a.shape[1:])}


def _nonmanifold_edges(t: np.ndarray, nv: int) -> int:
    """Count edges whose ring of tets is not one fan (a path or a cycle of tets)."""
    keys = edge_keys(t, nv)
    # the two tet vertices off each edge, in edge order of _EDGES: its complement
    other = np.array([[2, 3], [1, 3], [1, 2], [0, 3], [0, 2], [0, 1]], dtype=np.int64)
    link = np.sort(t[:, other], axis=2).reshape(-1, 2)
    order = np.argsort(keys, kind="stable")
    return int(_nonmanifold_edges_kernel(keys[order], link[order]))


# --- kernels (numba) --------------------------------------------------------------------


@kernel(inline=True)
def _find(parent, i):
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


HUB = 32  # a bucket larger than this is sorted rather than compared pair by pair
PARITY = np.int64(1) << 62


@kernel
def bucket_faces(t, nv):
    """The ``4 nt`` faces of ``t`` bucketed by their smallest vertex (a counting sort:
    reads go in order, no hashing). Returns ``start`` (bucket ``v`` is
    ``start[v]:start[v + 1]``), ``key = mid << 32 | max`` and ``fid = 4 j + i`` (face
    ``i`` of tet ``j``, opposite vertex ``i``) with bit 62 set when the sorted triple
    has the orientation opposite to the face as seen from outside its tet; two tets
    sharing a face with equal bits are oriented against each other. A bucket of more
    than :data:`HUB` faces (a hub vertex) comes sorted by key, so equal faces are
    neighbours there; smaller buckets are left in tet order."""
    nt = t.shape[0]
    start = np.zeros(nv + 1, dtype=np.int64)
    for j in range(nt):
        for i in range(4):
            start[min(t[j, (i + 1) % 4], t[j, (i + 2) % 4], t[j, (i + 3) % 4]) + 1] += 1
    for v in range(nv):
        start[v + 1] += start[v]
    fill = start[:nv].copy()
    key = np.empty(4 * nt, dtype=np.int64)
    fid = np.empty(4 * nt, dtype=np.int64)
    for j in range(nt):
        for i in range(4):
            a = np.int64(t[j, (i + 1) % 4])
            b = np.int64(t[j, (i + 2) % 4])
            c = np.int64(t[j, (i + 3) % 4])
            o = i & 1  # (i+1, i+2, i+3) faces out of the tet for even i
            if a > b:
                a, b = b, a
                o ^= 1
            if b > c:
                b, c = c, b
                o ^= 1
            if a > b:
                a, b = b, a
                o ^= 1
            p = fill[a]
            fill[a] += 1
            key[p] = (b << 32) | c
            fid[p] = (4 * j + i) | (np.int64(o) << 62)
    for v in range(nv):
        lo = start[v]
        hi = start[v + 1]
        if hi - lo > HUB:
            order = np.argsort(key[lo:hi], kind="mergesort")
            k2 = key[lo:hi][order]
            f2 = fid[lo:hi][order]
            key[lo:hi] = k2
            fid[lo:hi] = f2
    return start, key, fid


@kernel
def _face_adjacency_kernel(t, adj, nv):
    start, key, fid = bucket_faces(t, nv)
    low = PARITY - 1
    extra = 0
    for v in range(nv):
        lo = start[v]
        hi = start[v + 1]
        if hi - lo > HUB:
            run = 1
            for q in range(lo + 1, hi):
                if key[q] == key[q - 1]:
                    run += 1
                    if run == 2:
                        f = fid[q - 1] & low
                        g = fid[q] & low
                        adj[f // 4, f % 4] = g // 4
                        adj[g // 4, g % 4] = f // 4
                    elif run == 3:
                        extra += 1
                else:
                    run = 1
            continue
        for q in range(lo, hi):
            if fid[q] < 0:
                continue
            g = fid[q] & low
            seen = 1
            for r in range(q + 1, hi):
                if fid[r] >= 0 and key[r] == key[q]:
                    seen += 1
                    f = fid[r] & low
                    if seen == 2:
                        adj[f // 4, f % 4] = g // 4
                        adj[g // 4, g % 4] = f // 4
                    elif seen == 3:
                        extra += 1
                    fid[r] = -1
    return extra


@kernel
def _components_kernel(adj):
    nt = adj.shape[0]
    parent = np.arange(nt)
    for j in range(nt):
        for f in range(4):
            k = adj[j, f]
            if k >= 0:
                a = _find(parent, j)
                b = _find(parent, k)
                if a != b:
                    parent[max(a, b)] = min(a, b)
    label = np.full(nt, -1, dtype=np.int64)
    n = 0
    for j in range(nt):
        r = _find(parent, j)
        if label[r] < 0:
            label[r] = n
            n += 1
        label[j] = label[r]
    return label


@kernel
def _nonmanifold_edges_kernel(keys, link):
    """Each tet around an edge adds a link edge between its two other vertices; the ring
    is one fan when that link graph has degrees <= 2 and is connected."""
    m = keys.size
    count = 0
    i = 0
    verts = np.empty(64, dtype=np.int64)
    parent = np.empty(64, dtype=np.int64)
    deg = np.empty(64, dtype=np.int64)
    while i < m:
        j = i
        while j < m and keys[j] == keys[i]:
            j += 1
        n = j - i
        if 2 * n > verts.size:
            verts = np.empty(4 * n, dtype=np.int64)
            parent = np.empty(4 * n, dtype=np.int64)
            deg = np.empty(4 * n, dtype=np.int64)
        nverts = 0
        bad = False
        for r in range(i, j):
            ids = np.empty(2, dtype=np.int64)
            for s in range(2):
                v = link[r, s]
                found = -1
                for q in range(nverts):
                    if verts[q] == v:
                        found = q
                        break
                if found < 0:
                    found = nverts
                    verts[nverts] = v
                    parent[nverts] = nverts
                    deg[nverts] = 0
                    nverts += 1
                deg[found] += 1
                if deg[found] > 2:
                    bad = True
                ids[s] = found
            a = _find(parent, ids[0])
            b = _find(parent, ids[1])
            if a != b:
                parent[max(a, b)] = min(a, b)
        if not bad:
            roots = 0
            for q in range(nverts):
                if _find(parent, q) == q:
                    roots += 1
            bad = roots != 1
        if bad:
            count += 1
        i = j
    return count


@kernel
def _vertex_fans_kernel(t, adj, nv):
    """Number of face-connected groups of tets around each vertex (1 when manifold)."""
    nt = t.shape[0]
    parent = np.arange(4 * nt)  # one node per (tet, corner)
    for j in range(nt):
        for f in range(4):
            k = adj[j, f]
            if k < 0:
                continue
            # the three vertices of face f are shared with tet k: join their corners
            for c in range(4):
                if c == f:
                    continue
                v = t[j, c]
                for ck in range(4):
                    if t[k, ck] == v:
                        a = _find(parent, 4 * j + c)
                        b = _find(parent, 4 * k + ck)
                        if a != b:
                            parent[max(a, b)] = min(a, b)
                        break
    groups = np.zeros(nv, dtype=np.int64)
    for n in range(4 * nt):
        if _find(parent, n) == n:
            groups[t[n // 4, n % 4]] += 1
    return groups
