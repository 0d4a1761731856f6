"""Cut-border connectivity coding: round trips, odd meshes, stats, corrupt streams."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from naive_cutborder import (
    check_traversal,
    face_components,
    face_neighbours,
    order0_entropy,
    same_orientation,
)

from volpack.errors import FormatError, VolpackError
from volpack.tetra.cutborder import (
    _decode_payload,
    connectivity_stats,
    decode_connectivity,
    encode_connectivity,
)

# Kuhn's split of a cube into six tetrahedra along the diagonal 0 -> 7 (corner bits x, y,
# z); each listed so that it has positive volume.
KUHN = [(0, 1, 3, 7), (0, 5, 1, 7), (0, 3, 2, 7), (0, 2, 6, 7), (0, 4, 5, 7), (0, 6, 4, 7)]


def grid(nx, ny=None, nz=None, skip=()):
    """Tetrahedra of an nx x ny x nz block of cubes (6 each), cubes in ``skip`` left out."""
    ny = nx if ny is None else ny
    nz = nx if nz is None else nz

    def vid(i, j, k):
        return (k * (ny + 1) + j) * (nx + 1) + i

    out = []
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                if (i, j, k) in skip:
                    continue
                corner = [vid(i + (b & 1), j + (b >> 1 & 1), k + (b >> 2 & 1)) for b in range(8)]
                out += [[corner[c] for c in tet] for tet in KUHN]
    return np.array(out, dtype=np.int64).reshape(-1, 4), (nx + 1) * (ny + 1) * (nz + 1)


def signed_volume(pts, row):
    a, b, c, d = (pts[v] for v in row)
    return np.linalg.det(np.array([b - a, c - a, d - a]))


def roundtrip(tets, nv):
    tets = np.asarray(tets, dtype=np.int64).reshape(-1, 4)
    data, trav = encode_connectivity(tets, nv)
    dec = decode_connectivity(data)
    check_traversal(tets, nv, trav, dec)
    back = {tuple(sorted(r)) for r in trav.vertex_order[dec.tets].tolist()}
    assert back == {tuple(sorted(r)) for r in tets.tolist()}
    assert encode_connectivity(tets, nv)[0] == data  # deterministic
    return data, trav, dec


def fan(n):
    """A double cone: 2 n tets around the axis (0, 1), vertex 0 in all of them."""
    ring = [2 + i for i in range(n)]
    tets = []
    for i in range(n):
        a, b = ring[i], ring[(i + 1) % n]
        tets += [(0, a, b, 1), (0, b, a, n + 2)]
    return np.array(tets), n + 3


def test_grid_positive_volumes_keep_orientation():
    tets, nv = grid(3)
    g = np.arange(4)
    k, j, i = np.meshgrid(g, g, g, indexing="ij")
    pts = np.stack([i, j, k], -1).reshape(-1, 3).astype(float)
    assert all(signed_volume(pts, r) > 0 for r in tets)
    data, trav, dec = roundtrip(tets, nv)
    back = pts[trav.vertex_order]
    assert all(signed_volume(back, r) > 0 for r in dec.tets)
    s = connectivity_stats(tets, nv)
    assert s["orientation_exceptions"] == 0
    assert s["model_bits_orientation"] == 0.0


@pytest.mark.parametrize(
    "case",
    ["single", "vertex", "edge", "face", "cavity", "components", "all_border", "hub", "slab"],
)
def test_stability_cases(case):
    if case == "single":
        tets, nv = [[0, 1, 2, 3]], 4
    elif case == "vertex":  # two tets sharing one vertex only
        tets, nv = [[0, 1, 2, 3], [3, 4, 5, 6]], 7
    elif case == "edge":  # sharing an edge only (non-manifold edge)
        tets, nv = [[0, 1, 2, 3], [2, 3, 4, 5]], 6
    elif case == "face":
        tets, nv = [[0, 1, 2, 3], [1, 0, 2, 4]], 5
    elif case == "cavity":  # the middle cube of 3x3x3 missing: an inner border
        tets, nv = grid(3, skip={(1, 1, 1)})
    elif case == "components":
        a, na = grid(2)
        b, nb = grid(1, 2, 1)
        tets, nv = (
            np.concatenate([b + na, a, [[na + 100, na + 101, na + 102, na + 103]]]),
            (na + nb + 104),
        )
    elif case == "all_border":  # one layer of cubes: every vertex on the border
        tets, nv = grid(4, 3, 1)
    elif case == "hub":  # a vertex in 600 tets
        tets, nv = fan(300)
    else:  # cubes meeting at edges and corners only, one shared by five
        cells = {(0, 0, 0), (1, 1, 0), (0, 1, 1), (1, 0, 1), (2, 2, 2), (1, 1, 2)}
        tets, nv = grid(3, skip={c for c in np.ndindex(3, 3, 3) if c not in cells})
    tets = np.asarray(tets)
    used = np.unique(tets)
    data, trav, dec = roundtrip(tets, nv)
    assert (trav.gates[len(used) :] == -1).all()
    s = connectivity_stats(tets, nv)
    assert s["components"] == face_components(tets.tolist())
    assert s["b"] == face_neighbours(tets.tolist())[1]


def test_hub_and_far_vertices_are_coded():
    tets, nv = fan(300)
    s = connectivity_stats(tets, nv)
    assert s["t"] == 600 and s["components"] == 1 and s["far"] == 0
    # a second component reaches the first one's vertex 3 from inside: a "far" operation
    tets = [[0, 1, 2, 3], [4, 5, 6, 7], [4, 6, 5, 3]]
    roundtrip(tets, 8)
    s = connectivity_stats(tets, 8)
    assert (s["components"], s["far"], s["revisit"]) == (2, 1, 1)
    # a second component starting on a known vertex codes it in its first tetrahedron
    tets = [[0, 1, 2, 3], [3, 4, 5, 6]]
    s = connectivity_stats(tets, 7)
    assert s["components"] == 2 and s["model_bits_component_start"] > 0


def test_grid_with_random_holes(rng):
    """Random tets removed from a grid: many pieces touching at edges and vertices."""
    tets, nv = grid(4)
    for keep in (0.3, 0.6, 0.9):
        sub = tets[rng.random(len(tets)) < keep]
        roundtrip(sub, nv)
        s = connectivity_stats(sub, nv)
        assert s["components"] == face_components(sub.tolist())


def test_empty_and_unreferenced():
    for nv, empty in ((0, np.zeros((0, 4), dtype=np.int32)), (5, [])):
        data, trav = encode_connectivity(empty, nv)
        dec = decode_connectivity(data)
        assert dec.tets.shape == (0, 4) and dec.gates.shape == (nv, 3)
        assert trav.vertex_order.tolist() == list(range(nv))
    tets = np.array([[7, 2, 9, 4]])
    data, trav, dec = roundtrip(tets, 12)
    assert trav.vertex_order[:4].tolist() == [7, 2, 9, 4]
    assert trav.vertex_order[4:].tolist() == [0, 1, 3, 5, 6, 8, 10, 11]


def test_shuffled_relabelled_and_inverted(rng):
    tets, nv = grid(4)
    perm = rng.permutation(nv)
    tets = perm[tets][rng.permutation(len(tets))]
    flip = rng.random(len(tets)) < 0.1
    tets[flip] = tets[flip][:, [1, 0, 2, 3]]  # inverted tets are coded as exceptions
    roundtrip(tets, nv)
    s = connectivity_stats(tets, nv)
    assert 0 < s["orientation_exceptions"] < len(tets)


def test_grid_is_cheap():
    """A regular grid codes like the thesis's curvilinear Blunt Fin (1.31 bits per tet)."""
    tets, nv = grid(8)
    s = connectivity_stats(tets, nv)
    assert s["adaptive_bits_per_tet"] < 1.6
    assert s["nu_connect0"] > 0.6
    assert s["adaptive_bits_per_tet"] < s["grow_fold_bits"] / s["t"] / 4
    # the entropy column is the order-0 entropy of the coded symbols
    assert s["entropy_bits"] > 0
    assert s["ops_coded"] <= s["t_minus_1_plus_b"]


def test_stats_entropy_matches_naive():
    from volpack.tetra import _cutborder_kernels as k
    from volpack.tetra.cutborder import _run_encoder, _validate

    tets, nv = grid(3)
    a, nv = _validate(tets, nv)
    _, _, stats, hist, _, _ = _run_encoder(a, nv, measure=True)
    symbols = [i for i, c in enumerate(hist.tolist()) for _ in range(c)]
    s = connectivity_stats(tets, nv)
    assert abs(s["entropy_bits"] - order0_entropy(symbols)) < 1e-6
    assert sum(hist) == stats[k.S_OPS] == s["ops_coded"]


def test_bad_input_messages():
    with pytest.raises(FormatError, match="in \\[0, 4\\)"):
        encode_connectivity([[0, 1, 2, 4]], 4)
    with pytest.raises(FormatError, match="four distinct"):
        encode_connectivity([[0, 1, 1, 3]], 4)
    with pytest.raises(FormatError, match="distinct tetrahedra"):
        encode_connectivity([[0, 1, 2, 3], [3, 2, 1, 0]], 4)
    with pytest.raises(FormatError, match="at most two"):
        encode_connectivity([[0, 1, 2, 3], [0, 1, 2, 4], [0, 1, 2, 5]], 6)
    with pytest.raises(FormatError, match="\\(n, 4\\)"):
        encode_connectivity([[0, 1, 2]], 4)


def test_corrupt_streams_raise_volpack_errors(rng):
    tets, nv = grid(2)
    data, _ = encode_connectivity(tets, nv)
    for n in range(len(data)):
        with pytest.raises(FormatError):
            decode_connectivity(data[:n])
    for _ in range(200):
        bad = bytearray(data)
        bad[rng.integers(len(bad))] ^= 1 << int(rng.integers(8))
        with pytest.raises(VolpackError):
            decode_connectivity(bytes(bad))


def test_corrupt_payload_never_crashes(rng):
    """Past the checksum, the decoder itself must reject or survive any payload."""
    tets, nv = grid(2)
    data, trav = encode_connectivity(tets, nv)
    assert len(tets) < 128 and nv < 128  # one-byte counts: a 12-byte header
    payload = data[12:]
    nvu = len(np.unique(tets))
    good = _decode_payload(payload, len(tets), nv, nvu, 0)
    assert good.tets.tolist() == trav.tets.tolist()
    for n in range(len(payload)):
        try:
            _decode_payload(payload[:n], len(tets), nv, nvu, 0)
        except FormatError:
            pass
    for _ in range(300):
        bad = bytearray(payload)
        for _ in range(int(rng.integers(1, 4))):
            bad[rng.integers(1, len(bad))] = int(rng.integers(256))
        try:
            out = _decode_payload(bytes(bad), len(tets), nv, nvu, 0)
        except FormatError:
            continue
        assert out.tets.shape == (len(tets), 4)
        assert ((out.tets >= 0) & (out.tets < nvu)).all()


def test_limits_are_checked():
    tets, nv = grid(2)
    data, _ = encode_connectivity(tets, nv)
    with pytest.raises(FormatError, match="limit"):
        decode_connectivity(data, max_tets=10)
    forged = b"VTC1" + bytes([0xFF, 0xFF, 0xFF, 0x7F]) + data[5:]
    with pytest.raises(FormatError):
        decode_connectivity(forged)


@st.composite
def soups(draw):
    """Small random tetrahedron soups: any shape, faces in at most two tets."""
    nv = draw(st.integers(4, 9))
    quads = st.lists(st.integers(0, nv - 1), min_size=4, max_size=4, unique=True)
    rows = draw(st.lists(quads, min_size=0, max_size=14))
    out, faces, seen = [], {}, set()
    for r in rows:
        key = tuple(sorted(r))
        fs = [tuple(sorted(r[:lf] + r[lf + 1 :])) for lf in range(4)]
        if key in seen or any(faces.get(f, 0) >= 2 for f in fs):
            continue
        seen.add(key)
        for f in fs:
            faces[f] = faces.get(f, 0) + 1
        out.append(r)
    return np.array(out, dtype=np.int64).reshape(-1, 4), nv


@settings(max_examples=150)
@given(soups())
def test_random_soups_roundtrip(soup):
    tets, nv = soup
    roundtrip(tets, nv)


def test_decoded_orientation_matches_each_row(rng):
    tets, nv = grid(2, 2, 3)
    tets = tets[rng.permutation(len(tets))]
    swap = rng.random(len(tets)) < 0.5
    tets[swap] = tets[swap][:, [0, 2, 1, 3]]
    data, trav, dec = roundtrip(tets, nv)
    for j, row in enumerate(dec.tets.tolist()):
        src = tets[trav.tet_order[j]].tolist()
        assert same_orientation([int(trav.vertex_order[v]) for v in row], src)


@settings(max_examples=60)
@given(soups())
def test_face_neighbours_match_naive(soup):
    from volpack.tetra.cutborder import _neighbours

    tets, nv = soup
    if not len(tets):
        return
    nbr, inconsistent = _neighbours(np.ascontiguousarray(tets, dtype=np.int32))
    naive, _ = face_neighbours(tets.tolist())
    assert {(t, lf): int(nbr[t, lf]) for t in range(len(tets)) for lf in range(4)} == naive
    # two tets across a face agree in orientation iff their rows differ oddly there
    bad = 0
    for (t, lf), s in naive.items():
        if s > t:
            shared = [v for v in tets[t].tolist() if v != tets[t][lf]]
            a = shared + [int(tets[t][lf])]
            b = shared + [int(v) for v in tets[s].tolist() if v not in shared]
            bad += same_orientation(a, tets[t].tolist()) == same_orientation(b, tets[s].tolist())
    assert inconsistent == bad


def test_orientation_can_be_left_to_the_coder(rng):
    """Rows of random parity (as DOLFIN's sorted cells) cost about a bit per tet to keep."""
    tets, nv = grid(4)
    tets = np.sort(tets, axis=1)
    kept = connectivity_stats(tets, nv)
    free = connectivity_stats(tets, nv, keep_orientation=False)
    assert free["orientation_exceptions"] == 0 and free["model_bits_orientation"] == 0
    assert kept["stream_bytes"] - free["stream_bytes"] > 0.5 * len(tets) / 8
    data, trav = encode_connectivity(tets, nv, keep_orientation=False)
    dec = decode_connectivity(data)
    assert dec.tets.tolist() == trav.tets.tolist()
    back = {tuple(sorted(r)) for r in trav.vertex_order[dec.tets].tolist()}
    assert back == {tuple(sorted(r)) for r in tets.tolist()}
    # every decoded tet is oriented like its parent: the coded mesh is consistent
    order = trav.vertex_order
    for j, p in enumerate(dec.tet_parent.tolist()):
        if p >= 0:
            a, b = dec.tets[j].tolist(), dec.tets[p].tolist()
            shared = [v for v in a if v in b]
            sa = shared + [v for v in a if v not in shared]
            sb = shared + [v for v in b if v not in shared]
            assert same_orientation(sa, a) != same_orientation(sb, b)
    assert len(order) == nv


@settings(max_examples=60)
@given(soups())
def test_coding_order_adjacency_matches_naive(soup):
    # the encoder hands its face neighbours, renumbered into coding order, to the
    # coordinate coder: they must be the neighbours of the coded tets
    tets, nv = soup
    _, trav = encode_connectivity(tets, nv)
    naive, _ = face_neighbours(np.asarray(trav.tets).tolist())
    got = {(t, lf): int(trav.adjacency[t, lf]) for t in range(len(tets)) for lf in range(4)}
    assert got == naive
