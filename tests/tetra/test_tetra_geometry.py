"""Vertex coordinates and point/cell data: round trips, error bounds, rates, corruption.

The coders are run on a breadth-first reference traversal (``tetra_meshes``) and on the
cut-border coder's own traversal.
"""

from __future__ import annotations

import numpy as np
import pytest
from tetra_meshes import bfs_traversal, grid_mesh

from volpack.errors import FormatError
from volpack.tetra import cutborder
from volpack.tetra.attributes import cell_refs, decode_attribute, encode_attribute
from volpack.tetra.geometry import decode_geometry, encode_geometry, prediction_faces
from volpack.tetra.packages import from_ordered_bits, ordered_bits


@pytest.fixture(scope="module")
def mesh():
    return grid_mesh(5, jitter=0.25, seed=3)


@pytest.fixture(scope="module", params=["bfs", "cutborder"])
def trav(request, mesh):
    if request.param == "bfs":
        return bfs_traversal(mesh.tets, mesh.n_vertices)
    return cutborder.encode_connectivity(mesh.tets, mesh.n_vertices)[1]


def quantize_reference(p, meta):
    """The grid point each coordinate must decode to, computed the obvious way."""
    o, s = np.array(meta["origin"]), meta["step"]
    q = np.clip(np.rint((p.astype(np.float64) - o) / s), 0, 2 ** meta["bits"] - 1)
    return (o + q * s).astype(p.dtype)


@pytest.mark.parametrize("bits", [8, 16, 24])
def test_quantized_round_trip_and_bound(mesh, trav, bits):
    pts = mesh.points[trav.vertex_order]
    data, meta = encode_geometry(pts, trav.tets, bits=bits)
    back = decode_geometry(data, meta, trav.tets, len(pts))
    np.testing.assert_array_equal(back, quantize_reference(pts, meta))
    diag = np.linalg.norm(pts.max(0) - pts.min(0))
    assert np.abs(back - pts).max() <= diag / (2**bits - 1) / 2 * (1 + 1e-9)
    assert meta["max_error"] == pytest.approx(np.abs(back - pts).max())


def test_rate_at_16_bits_beats_raw_by_far(mesh, trav):
    pts = mesh.points[trav.vertex_order]
    data, _ = encode_geometry(pts, trav.tets, bits=16)
    assert 8 * len(data) / len(pts) < 44  # raw 16-bit is 48; the prediction saves more


def test_prediction_beats_previous_vertex(mesh, trav):
    """The faces carry the prediction: without them (no tets) the same coder costs more."""
    pts = mesh.points[trav.vertex_order]
    with_faces, _ = encode_geometry(pts, trav.tets)
    without, _ = encode_geometry(pts, np.zeros((0, 4), dtype=np.int64))
    assert len(with_faces) < 0.95 * len(without)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_lossless_exact_with_nan_inf(mesh, trav, dtype):
    pts = mesh.points[trav.vertex_order].astype(dtype)
    pts[3, 1] = np.nan
    pts[7, 0] = np.inf
    pts[9, 2] = -0.0
    data, meta = encode_geometry(pts, trav.tets, lossless=True)
    back = decode_geometry(data, meta, trav.tets, len(pts))
    assert back.dtype == dtype
    np.testing.assert_array_equal(back.view(f"u{back.itemsize}"), pts.view(f"u{pts.itemsize}"))


def test_quantized_refuses_nan(mesh, trav):
    pts = mesh.points[trav.vertex_order].copy()
    pts[0, 0] = np.nan
    with pytest.raises(FormatError, match="lossless_geometry"):
        encode_geometry(pts, trav.tets)


def test_prediction_faces_naive(mesh, trav):
    """Every listed face is opposite k in a tet, precedes k, and has its far vertex < k."""
    t = np.asarray(trav.tets, dtype=np.int64)
    ptr, quads = prediction_faces(t, mesh.n_vertices)
    faces_of = {}
    for row in t:
        for i in range(4):
            faces_of.setdefault(tuple(sorted(np.delete(row, i))), set()).add(int(row[i]))
    count = 0
    for k in range(mesh.n_vertices):
        for a, b, c, w in quads[ptr[k] : ptr[k + 1]]:
            assert max(a, b, c, w) < k
            assert faces_of[tuple(sorted((a, b, c)))] == {k, w}
            count += 1
    expected = sum(1 for f, apexes in faces_of.items() if len(apexes) == 2 and max(f) < max(apexes))
    assert count == expected


def test_geometry_corrupt_streams_raise(mesh, trav):
    pts = mesh.points[trav.vertex_order]
    data, meta = encode_geometry(pts, trav.tets)
    for cut in (0, 1, len(data) // 3, len(data) - 5):
        with pytest.raises(FormatError):
            decode_geometry(data[:cut], meta, trav.tets, len(pts))
    with pytest.raises(FormatError, match="geometry parameters"):
        decode_geometry(data, {**meta, "bits": 99}, trav.tets, len(pts))


# --- attributes ----------------------------------------------------------------------------


def _refs(trav):
    return np.asarray(trav.gates, dtype=np.int64)


@pytest.mark.parametrize(
    "dtype", [np.int8, np.uint8, np.int32, np.uint32, np.int64, np.uint64, np.bool_, np.float16]
)
def test_attribute_exact_round_trip(trav, dtype):
    rng = np.random.default_rng(0)
    n = len(trav.gates)
    info = np.iinfo(dtype) if np.dtype(dtype).kind in "iu" else None
    if info is not None:
        vals = rng.integers(info.min, info.max, size=(n, 2), dtype=dtype, endpoint=True)
        vals[:4] = [[info.min, info.max]] * 4
    elif dtype is np.bool_:
        vals = rng.random((n, 2)) < 0.3
    else:
        vals = rng.normal(size=(n, 2)).astype(dtype)
    data, meta = encode_attribute(vals, _refs(trav))
    back = decode_attribute(data, meta, _refs(trav))
    assert back.dtype == vals.dtype and back.shape == vals.shape
    np.testing.assert_array_equal(back, vals)


def test_attribute_float_exact_and_tensor(mesh, trav):
    pts = mesh.points[trav.vertex_order]
    tensor = np.einsum("ni,nj->nij", pts, pts).astype(np.float32)  # (n, 3, 3)
    tensor[5, 1, 1] = np.nan
    data, meta = encode_attribute(tensor, _refs(trav))
    back = decode_attribute(data, meta, _refs(trav))
    np.testing.assert_array_equal(back.view(np.uint32), tensor.view(np.uint32))


@pytest.mark.parametrize("err", [1e-6, 1e-3, 0.5])
def test_attribute_bounded_error_held_everywhere(mesh, trav, err):
    pts = mesh.points[trav.vertex_order]
    f = (np.sin(pts[:, 0]) * 100 + pts[:, 1]).astype(np.float32)
    data, meta = encode_attribute(f, _refs(trav), max_error=err)
    back = decode_attribute(data, meta, _refs(trav))
    assert meta["mode"] == "bounded"
    assert np.abs(back.astype(np.float64) - f).max() <= err
    assert meta["max_error"] <= err
    exact, _ = encode_attribute(f, _refs(trav))
    if err >= 1e-3:
        assert len(data) < 0.75 * len(exact)


def test_attribute_bounded_refuses_nan(trav):
    f = np.zeros(len(trav.gates))
    f[1] = np.nan
    with pytest.raises(FormatError, match="NaN"):
        encode_attribute(f, _refs(trav), max_error=0.1)


def test_cell_data_material_ids_cost_little(mesh, trav):
    t = np.asarray(trav.tets)
    mat = (mesh.points[trav.vertex_order][t].mean(axis=1)[:, 0] > 2.5).astype(np.int32)
    refs = cell_refs(trav.tet_parent)
    data, meta = encode_attribute(mat, refs)
    np.testing.assert_array_equal(decode_attribute(data, meta, refs), mat)
    assert 8 * len(data) / len(mat) < 1.0  # of 32 raw


def test_attribute_corrupt_raises(trav):
    vals = np.arange(len(trav.gates), dtype=np.int64) ** 3
    data, meta = encode_attribute(vals, _refs(trav))
    with pytest.raises(FormatError):
        decode_attribute(data[: len(data) // 2], meta, _refs(trav))
    with pytest.raises(FormatError, match="attribute parameters"):
        decode_attribute(data, {**meta, "width": 40}, _refs(trav))


def test_ordered_bits_is_monotone_and_invertible():
    x = np.array([-np.inf, -3.5, -1e-30, -0.0, 0.0, 1e-30, 2.0, np.inf], dtype=np.float64)
    o = ordered_bits(x)
    assert (np.diff(o) > 0).all()
    np.testing.assert_array_equal(
        from_ordered_bits(o, np.float64).view(np.uint64), x.view(np.uint64)
    )
    x32 = x.astype(np.float32)
    np.testing.assert_array_equal(from_ordered_bits(ordered_bits(x32), np.float32), x32)


def test_lossless_takes_xor_zstd_for_repeating_coordinates():
    m = grid_mesh(4)  # integer coordinates on a grid: exact repeats
    trav = cutborder.encode_connectivity(m.tets, m.n_vertices)[1]
    pts = m.points[trav.vertex_order]
    data, meta = encode_geometry(pts, trav.tets, lossless=True)
    assert meta["mode"] == "lossless-xor"
    np.testing.assert_array_equal(decode_geometry(data, meta, trav.tets, len(pts)), pts)
    with pytest.raises(FormatError, match="corrupt geometry"):
        decode_geometry(data[:-3], meta, trav.tets, len(pts))
