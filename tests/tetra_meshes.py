"""Small tetrahedral meshes made in code, and a breadth-first reference traversal.

The traversal has the fields of the connectivity coder's ``Traversal`` (coding-order
tets, vertex and tet order, gates, parent tets), built the obvious way: tets breadth
first across faces, vertices numbered when first met. Geometry and attribute coders are
tested against it independently of the cut-border machine.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from volpack.tetra.formats import tetrahedralize
from volpack.tetra.mesh import FACES, TetMesh, face_adjacency


@dataclass(frozen=True)
class BfsTraversal:
    tets: np.ndarray
    vertex_order: np.ndarray
    tet_order: np.ndarray
    gates: np.ndarray
    tet_parent: np.ndarray


def bfs_traversal(tets: np.ndarray, nv: int) -> BfsTraversal:
    tets = np.asarray(tets, dtype=np.int64)
    nt = len(tets)
    adj, _ = face_adjacency(tets)
    new_id = np.full(nv, -1, dtype=np.int64)
    order, gates = [], []
    tet_order, parents = [], []
    pos = np.full(nt, -1, dtype=np.int64)
    for start in range(nt):
        if pos[start] >= 0:
            continue
        pos[start] = len(tet_order)
        queue = deque([(start, -1, None)])
        while queue:
            j, parent, gate = queue.popleft()
            tet_order.append(j)
            parents.append(parent)
            for v in tets[j]:
                if new_id[v] < 0:
                    new_id[v] = len(order)
                    order.append(int(v))
                    gates.append([-1, -1, -1] if gate is None else [int(new_id[g]) for g in gate])
            for f in range(4):
                k = adj[j, f]
                if k >= 0 and pos[k] < 0:
                    pos[k] = len(tet_order) + len(queue)
                    queue.append((int(k), pos[j], tets[j, FACES[f]]))
    gates_a = np.asarray(gates, dtype=np.int32).reshape(-1, 3)
    return BfsTraversal(
        tets=new_id[tets[np.asarray(tet_order, dtype=np.int64)]].astype(np.int32).reshape(-1, 4),
        vertex_order=np.asarray(order, dtype=np.int64),
        tet_order=np.asarray(tet_order, dtype=np.int64),
        gates=gates_a,
        tet_parent=np.asarray(parents, dtype=np.int32),
    )


def grid_mesh(n: int = 4, jitter: float = 0.0, seed: int = 0) -> TetMesh:
    """A cube of n^3 hexahedra split into 6 n^3 tets, vertices optionally jittered."""
    g = np.arange(n + 1)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    pts = np.stack([x, y, z], axis=-1).reshape(-1, 3).astype(np.float64)
    if jitter:
        pts += np.random.default_rng(seed).uniform(-jitter, jitter, pts.shape)

    def idx(i, j, k):
        return (k * (n + 1) + j) * (n + 1) + i

    c = np.arange(n)
    k, j, i = (a.reshape(-1) for a in np.meshgrid(c, c, c, indexing="ij"))
    hexes = np.stack(
        [idx(i, j, k), idx(i + 1, j, k), idx(i + 1, j + 1, k), idx(i, j + 1, k),
         idx(i, j, k + 1), idx(i + 1, j, k + 1), idx(i + 1, j + 1, k + 1), idx(i, j + 1, k + 1)],
        axis=1,
    )  # fmt: skip
    return TetMesh(pts, tetrahedralize("hexahedron", hexes, pts))


def golden_mesh() -> TetMesh:
    """The mesh of ``formats/examples/mesh-1-grid.vpk``: a 2x2x2-hex grid in tets with
    integer coordinates, a float point field and integer material ids."""
    m = grid_mesh(2)
    m.point_data["T"] = (m.points @ np.array([0.5, 0.25, 2.0])).astype(np.float32)
    m.cell_data["mat"] = (np.arange(m.n_tets) // 12).astype(np.int32)
    return m


def sphere_fan(n_lat=10, n_lon=24):
    """One vertex shared by every tet: a centre coned to a latitude-longitude sphere."""
    th = np.linspace(0, np.pi, n_lat + 1)[1:-1]
    ph = np.linspace(0, 2 * np.pi, n_lon, endpoint=False)
    ring = [[np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)] for t in th for p in ph]
    pts = np.array([[0, 0, 0], [0, 0, 1], *ring, [0, 0, -1]], dtype=np.float64)
    top, bottom = 1, len(pts) - 1

    def r(i, j):
        return 2 + i * n_lon + j % n_lon

    tris = [(top, r(0, j), r(0, j + 1)) for j in range(n_lon)]
    for i in range(n_lat - 2):
        for j in range(n_lon):
            tris += [
                (r(i, j), r(i + 1, j), r(i + 1, j + 1)),
                (r(i, j), r(i + 1, j + 1), r(i, j + 1)),
            ]
    tris += [(bottom, r(n_lat - 2, j + 1), r(n_lat - 2, j)) for j in range(n_lon)]
    tets = np.array([[0, *t] for t in tris])
    return TetMesh(pts, tets)
