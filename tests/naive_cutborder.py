"""Slow, obvious references for the cut-border connectivity coder.

Everything here works on Python sets and dicts, straight from the definitions: face
adjacency by a dictionary of sorted vertex triples, orientation as the parity of a vertex
permutation, and a checker of every promise a :class:`Traversal` makes.
"""

from __future__ import annotations

import math
from collections import Counter


def parity(perm) -> int:
    """0 for an even permutation of distinct values (relative to their sorted order), else 1."""
    p = list(perm)
    inv = sum(1 for i in range(len(p)) for j in range(i + 1, len(p)) if p[i] > p[j])
    return inv & 1


def same_orientation(row_a, row_b) -> bool:
    """True if two orderings of the same four vertices differ by an even permutation."""
    pos = {v: i for i, v in enumerate(row_b)}
    return parity([pos[v] for v in row_a]) == 0


def face_neighbours(tets):
    """{(t, lf): tet across the face opposite vertex lf or -1}, and the number of border faces."""
    owners: dict[tuple, list] = {}
    for t, row in enumerate(tets):
        for lf in range(4):
            key = tuple(sorted(int(row[m]) for m in range(4) if m != lf))
            owners.setdefault(key, []).append((t, lf))
    nbr = {}
    border = 0
    for own in owners.values():
        assert len(own) <= 2
        if len(own) == 1:
            border += 1
            nbr[own[0]] = -1
        else:
            (t, lf), (s, m) = own
            nbr[(t, lf)] = s
            nbr[(s, m)] = t
    return nbr, border


def face_components(tets) -> int:
    """Number of face-connected components (union-find over shared faces)."""
    parent = list(range(len(tets)))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    nbr, _ = face_neighbours(tets)
    for (t, _l), s in nbr.items():
        if s >= 0:
            parent[find(t)] = find(s)
    return len({find(t) for t in range(len(tets))})


def order0_entropy(symbols) -> float:
    """Bits of an ideal order-0 code of a symbol sequence: -sum n_a log2(n_a / n)."""
    c = Counter(symbols)
    n = sum(c.values())
    return -sum(k * math.log2(k / n) for k in c.values())


def check_traversal(tets, n_vertices, trav, decoded) -> None:
    """Assert every promise of an encoder Traversal against the input and the decoder's."""
    tets = [tuple(int(v) for v in row) for row in tets]
    nt = len(tets)
    assert decoded.tets.tolist() == trav.tets.tolist()
    assert decoded.gates.tolist() == trav.gates.tolist()
    assert decoded.tet_parent.tolist() == trav.tet_parent.tolist()
    assert decoded.vertex_order.tolist() == list(range(n_vertices))
    assert decoded.tet_order.tolist() == list(range(nt))
    order = trav.vertex_order.tolist()
    assert sorted(order) == list(range(n_vertices))
    assert sorted(trav.tet_order.tolist()) == list(range(nt))
    used = {v for row in tets for v in row}
    # used vertices first, numbered where first met; unreferenced ones last, input order
    n_used = len(used)
    assert set(order[:n_used]) == used
    assert order[n_used:] == sorted(set(range(n_vertices)) - used)
    seen = -1
    for row in trav.tets.tolist():
        for v in row:
            assert v <= seen + 1
            seen = max(seen, v)
    # each coded tet is its input row, renumbered, with the same orientation
    for j, row in enumerate(trav.tets.tolist()):
        src = tets[int(trav.tet_order[j])]
        mapped = tuple(order[v] for v in row)
        assert sorted(mapped) == sorted(src)
        assert same_orientation(mapped, src)
    # parents share a face with their child and come earlier; gates are those faces
    first_tet = {}
    for j, row in enumerate(trav.tets.tolist()):
        for v in row:
            first_tet.setdefault(v, j)
        p = int(trav.tet_parent[j])
        if p >= 0:
            assert p < j
            assert len(set(row) & set(trav.tets[p].tolist())) == 3
    for k in range(n_vertices):
        g = trav.gates[k].tolist()
        if g == [-1, -1, -1]:
            continue
        assert all(0 <= x < k for x in g)
        j = first_tet[k]
        row = trav.tets[j].tolist()
        assert set(row) == set(g) | {k}
        assert same_orientation(tuple(g) + (k,), row) or same_orientation(
            (g[1], g[0], g[2], k), row
        )
        assert set(g) <= set(trav.tets[int(trav.tet_parent[j])].tolist())
