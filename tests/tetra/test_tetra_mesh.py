"""The mesh model: validation, the report's counts, face adjacency, meshio I/O, splitting."""

from __future__ import annotations

import warnings

import meshio
import numpy as np
import pytest
from conftest import need
from tetra_meshes import grid_mesh, sphere_fan

from volpack.errors import FormatError
from volpack.tetra import is_mesh_path
from volpack.tetra.formats import MeshWarning, read_mesh, tetrahedralize, write_mesh
from volpack.tetra.mesh import FACES, TetMesh, face_adjacency, report, signed_volumes, validate

UNIT = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)


def naive_adjacency(tets):
    """Face -> tets with a dict of sorted triples."""
    faces = {}
    for j, t in enumerate(tets):
        for i in range(4):
            faces.setdefault(tuple(sorted(t[FACES[i]])), []).append((j, i))
    adj = -np.ones((len(tets), 4), dtype=np.int64)
    for users in faces.values():
        if len(users) == 2:
            (j, i), (k, f) = users
            adj[j, i], adj[k, f] = k, j
    return adj


def test_faces_keep_the_orientation():
    for i in range(4):
        a, b, c = UNIT[FACES[i]]
        assert np.dot(np.cross(b - a, c - a), UNIT[i] - a) > 0  # (face, vertex i) is positive


@pytest.mark.parametrize("make", [lambda: grid_mesh(3, jitter=0.1), sphere_fan])
def test_face_adjacency_matches_naive(make):
    m = make()  # the fan's centre has a bucket of 1000+ faces (the sorted path)
    adj, nm = face_adjacency(m.tets)
    assert nm == 0
    np.testing.assert_array_equal(adj, naive_adjacency(m.tets))


def test_report_grid_counts():
    n = 3
    r = report(grid_mesh(n))
    assert r["vertices"] == (n + 1) ** 3 and r["tets"] == 6 * n**3
    assert r["border_faces"] == 6 * 2 * n * n  # two triangles per boundary square
    assert r["euler"] == 1 and r["components"] == 1
    assert r["faces"] == 2 * r["tets"] + r["border_faces"] // 2  # f = 2t + b/2 (3.3)
    assert r["inverted"] == r["zero_volume"] == r["negative_volume"] == 0
    assert r["nonmanifold_edges"] == r["nonmanifold_vertices"] == r["nonmanifold_faces"] == 0
    assert r["border_vertices"] == (n + 1) ** 3 - (n - 1) ** 3


def test_report_single_tet():
    r = report(TetMesh(UNIT, [[0, 1, 2, 3]]))
    assert (r["vertices"], r["edges"], r["faces"], r["tets"], r["euler"]) == (4, 6, 4, 1, 1)


def test_report_nonmanifold_vertex_and_edge():
    pts = np.vstack([UNIT, UNIT[1:] * -1.0])  # a second tet through vertex 0 only
    r = report(TetMesh(pts, [[0, 1, 2, 3], [0, 6, 5, 4]]))
    assert r["nonmanifold_vertices"] == 1 and r["nonmanifold_edges"] == 0
    assert r["components"] == 2
    pts = np.vstack([UNIT, [[0.5, -1, -1], [1, -1, 1]]])  # edge 0-1 shared only
    r = report(TetMesh(pts, [[0, 1, 2, 3], [0, 1, 4, 5]]))
    assert r["nonmanifold_edges"] == 1 and r["nonmanifold_vertices"] == 2


def test_report_inverted_zero_unreferenced_duplicate():
    m = grid_mesh(2)
    tets = m.tets.copy()
    tets[0] = tets[0][[1, 0, 2, 3]]  # one inverted
    pts = np.vstack([m.points, [[5, 5, 5], m.points[0]]])  # one unreferenced, one duplicate
    flat = len(pts)
    pts = np.vstack([pts, [[9, 0, 0], [10, 0, 0], [9, 1, 0], [10, 1, 0]]])  # coplanar
    tets = np.vstack([tets, [[flat, flat + 1, flat + 2, flat + 3]]])
    r = report(TetMesh(pts, tets))
    assert r["inverted"] == 1 and r["negative_volume"] == 1 and r["zero_volume"] == 1
    assert r["unreferenced_vertices"] == 2 and r["duplicate_vertices"] == 1


@pytest.mark.parametrize(
    ("tets", "what"),
    [
        ([[0, 1, 2, 4]], "expected 0..3"),
        ([[0, 1, -1, 2]], "expected 0..3"),
        ([[0, 1, 1, 2]], "repeat"),
    ],
)
def test_validate_refuses(tets, what):
    with pytest.raises(FormatError, match=what):
        validate(TetMesh(UNIT, tets))


def test_model_refuses_bad_shapes():
    with pytest.raises(FormatError, match=r"\(nv, 3\)"):
        TetMesh(np.zeros((4, 2)), [[0, 1, 2, 3]])
    with pytest.raises(FormatError, match=r"\(nt, 4\)"):
        TetMesh(UNIT, [[0, 1, 2]])
    with pytest.raises(FormatError, match="expected 4 rows"):
        TetMesh(UNIT, [[0, 1, 2, 3]], point_data={"a": np.zeros(3)})


@pytest.mark.parametrize("kind", ["hexahedron", "wedge", "pyramid"])
def test_tetrahedralize_positive_and_volume_preserving(kind):
    cells = {
        "hexahedron": [
            [0, 0, 0],
            [1, 0, 0],
            [1, 1, 0],
            [0, 1, 0],
            [0, 0, 1],
            [1, 0, 1],
            [1, 1, 1],
            [0, 1, 1],
        ],
        "wedge": [[0, 0, 0], [0, 1, 0], [1, 0, 0], [0, 0, 1], [0, 1, 1], [1, 0, 1]],
        "pyramid": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]],
    }[kind]
    volume = {"hexahedron": 1.0, "wedge": 0.5, "pyramid": 1 / 3}[kind]
    rng = np.random.default_rng(1)
    for _ in range(6):  # every numbering: the split depends on global indices
        perm = rng.permutation(len(cells))
        pts = np.empty((len(cells), 3))
        pts[perm] = cells
        t = tetrahedralize(kind, perm[None, :], pts)
        v = signed_volumes(pts, t) / 6
        assert (v > 0).all()
        assert v.sum() == pytest.approx(volume)


def test_tetrahedralize_conforms_between_cells():
    # a 3x3x3 block of hexes: a conforming split has no face used once inside the block
    r = report(grid_mesh(3))
    assert r["border_faces"] == 6 * 2 * 9 and r["nonmanifold_faces"] == 0


def test_meshio_round_trip(tmp_path):
    m = grid_mesh(2, jitter=0.1)
    m.point_data["T"] = m.points[:, 0].copy()
    m.cell_data["mat"] = np.arange(m.n_tets, dtype=np.int32) % 3
    path = tmp_path / "m.vtu"
    write_mesh(m, str(path))
    back = read_mesh(str(path))
    np.testing.assert_array_equal(back.points, m.points)
    np.testing.assert_array_equal(back.tets, m.tets)
    np.testing.assert_array_equal(back.point_data["T"], m.point_data["T"])
    np.testing.assert_array_equal(back.cell_data["mat"], m.cell_data["mat"])
    assert not list(tmp_path.glob(".volpack-*"))  # the temporary file was renamed


def test_hexahedra_refused_or_split(tmp_path):
    pts = np.array(
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]],
        float,
    )
    path = tmp_path / "hex.vtu"
    meshio.write(
        str(path), meshio.Mesh(pts, [("hexahedron", np.arange(8)[None])], cell_data={"id": [[7]]})
    )
    with pytest.raises(FormatError, match="tetrahedralize=True"):
        read_mesh(str(path))
    m = read_mesh(str(path), tetrahedralize=True)
    assert m.n_tets == 6 and (m.cell_data["id"] == 7).all()


def test_tetra10_keeps_corners_with_warning(tmp_path):
    pts = np.vstack(
        [
            UNIT,
            [(UNIT[a] + UNIT[b]) / 2 for a, b in [(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)]],
        ]
    )
    pts = np.vstack([pts, [[7, 7, 7]]])  # an unreferenced vertex stays
    path = tmp_path / "q.vtu"
    meshio.write(
        str(path),
        meshio.Mesh(pts, [("tetra10", np.arange(10)[None])], point_data={"p": np.arange(11.0)}),
    )
    with pytest.warns(MeshWarning, match="tetra10"):
        m = read_mesh(str(path))
    np.testing.assert_array_equal(m.tets, [[0, 1, 2, 3]])
    np.testing.assert_array_equal(m.points, pts[[0, 1, 2, 3, 10]])
    np.testing.assert_array_equal(m.point_data["p"], [0, 1, 2, 3, 10])


def test_lower_dimensional_cells_dropped_with_warning(tmp_path):
    path = tmp_path / "m.vtu"
    meshio.write(
        str(path), meshio.Mesh(UNIT, [("tetra", [[0, 1, 2, 3]]), ("triangle", [[0, 1, 2]])])
    )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = read_mesh(str(path))
    assert m.n_tets == 1 and any("triangle" in str(w.message) for w in caught)


def test_is_mesh_path():
    assert is_mesh_path("a.vtu") and is_mesh_path("b.XML.gz") and is_mesh_path("c.msh")
    assert not is_mesh_path("ct.nii.gz") and not is_mesh_path("x.vpk") and not is_mesh_path("s.stl")


def test_exodus_through_its_extra_and_meshio_failures_say_what_was_expected(tmp_path, monkeypatch):
    need("netCDF4", "exodus")
    mesh = grid_mesh(2)
    m = meshio.Mesh(mesh.points, [("tetra", mesh.tets)],
                    point_data={"temperature": np.arange(len(mesh.points), dtype=float)})  # fmt: skip
    meshio.write(tmp_path / "disk.e", m)
    back = read_mesh(str(tmp_path / "disk.e"))
    np.testing.assert_array_equal(back.tets, mesh.tets)
    np.testing.assert_allclose(back.points, mesh.points)
    (tmp_path / "bad.e").write_bytes(b"CDF\x01" + bytes(60))  # a netCDF file without Exodus fields
    with pytest.raises(FormatError, match=r"expected the field 'num_nodes' in this \.e mesh"):
        read_mesh(str(tmp_path / "bad.e"))
    monkeypatch.setitem(__import__("sys").modules, "netCDF4", None)  # as if not installed
    with pytest.raises(FormatError, match=r"expected netCDF4 .* pip install 'volpack\[exodus\]'"):
        read_mesh(str(tmp_path / "disk.e"))
