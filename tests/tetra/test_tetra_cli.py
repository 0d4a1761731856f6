"""The mesh stream end to end: stability cases, kept order, corruption, and the CLI."""

from __future__ import annotations

import io
import json
import os
from pathlib import Path

import meshio
import numpy as np
import pytest
from click.testing import CliRunner
from tetra_meshes import golden_mesh, grid_mesh, sphere_fan

from volpack.cli import main
from volpack.errors import FormatError, OptionError
from volpack.format.container import Reader, Writer
from volpack.tetra.mesh import FACES, TetMesh, face_adjacency, signed_volumes
from volpack.tetra.stream import check_header, compress_mesh, decompress_mesh

UNIT = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)


def tet_keys(points, tets, parity=True):
    """Each tet as (sorted coordinate quadruple, orientation parity): order-free, sign-aware
    (or sign-blind with ``parity=False``)."""
    keys = []
    for row in np.asarray(tets):
        corners = [tuple(points[v].tolist()) for v in row]
        order = sorted(range(4), key=lambda i: corners[i])
        inversions = sum(order[i] > order[j] for i in range(4) for j in range(i + 1, 4))
        keys.append((tuple(corners[i] for i in order), inversions % 2 if parity else 0))
    return sorted(keys)


def same_tets(back, hdr, points, tets):
    """The decoded tets are the input's: with their parity, or for ascending input rows
    (``rows: sorted``) as ascending rows whose parity carries no meaning."""
    parity = hdr.get("rows", "parity") != "sorted"
    if not parity:
        assert (back.tets[:, 1:] > back.tets[:, :-1]).all()
    assert tet_keys(back.points, back.tets, parity) == tet_keys(points, tets, parity)


def quantized(points, hdr):
    g = hdr["geometry"]
    o, s = np.array(g["origin"]), g["step"]
    q = np.clip(np.rint((points.astype(np.float64) - o) / s), 0, 2 ** g["bits"] - 1)
    return (o + q * s).astype(points.dtype)


def round_trip(mesh, **options):
    buf = io.BytesIO()
    stats = compress_mesh(mesh, buf, **options)
    blob = buf.getvalue()
    with Reader(io.BytesIO(blob)) as r:
        hdr = r.header
    return decompress_mesh(blob), hdr, stats, blob


def stability_cases():
    cases = {"single tet": TetMesh(UNIT, [[0, 1, 2, 3]])}
    pts = np.vstack([UNIT, -UNIT[1:]])
    cases["share a vertex"] = TetMesh(pts, [[0, 1, 2, 3], [0, 5, 4, 6]])
    pts = np.vstack([UNIT, [[0.5, -1, -1], [1, -1, 1]]])
    cases["share an edge"] = TetMesh(pts, [[0, 1, 2, 3], [0, 1, 4, 5]])
    g = grid_mesh(3)
    centre = np.all(
        (g.points[g.tets].mean(axis=1) > 1) & (g.points[g.tets].mean(axis=1) < 2), axis=1
    )
    cases["cavity"] = TetMesh(g.points, g.tets[~centre])
    a, b = grid_mesh(2), grid_mesh(1)
    cases["components"] = TetMesh(
        np.vstack([a.points, b.points + 5]), np.vstack([a.tets, b.tets + a.n_vertices])
    )
    cases["all on the border"] = grid_mesh(1)
    cases["high valence"] = sphere_fan()
    g = grid_mesh(2, jitter=0.1)
    tets = g.tets.copy()
    tets[3] = tets[3][[1, 0, 2, 3]]  # inverted
    adj, _ = face_adjacency(g.tets)
    j, i = np.argwhere(adj < 0)[0]
    border = g.tets[j, FACES[i]]  # glue a flat tet onto a border face
    p = np.vstack([g.points, g.points[border].mean(axis=0)])
    tets = np.vstack([tets, [[*border, len(p) - 1]]])
    cases["inverted and flat"] = TetMesh(p, tets)
    cases["empty"] = TetMesh(np.zeros((0, 3)), np.zeros((0, 4), dtype=np.int64))
    cases["points only"] = TetMesh(UNIT, np.zeros((0, 4), dtype=np.int64))
    return cases


CASES = stability_cases()


@pytest.mark.parametrize("name", list(CASES))
def test_stability_case_round_trips(name):
    mesh = CASES[name]
    mesh.point_data["id"] = np.arange(mesh.n_vertices, dtype=np.int32)
    mesh.cell_data["mat"] = (np.arange(mesh.n_tets) % 3).astype(np.uint8)
    back, hdr, stats, _ = round_trip(mesh, lossless_geometry=True)
    same_tets(back, hdr, mesh.points, mesh.tets)
    assert back.n_vertices == mesh.n_vertices
    # point data travel with their vertex, cell data with their tet
    np.testing.assert_array_equal(back.points, mesh.points[back.point_data["id"]])
    order = {k: i for i, k in enumerate(map(tuple, np.sort(mesh.tets, axis=1).tolist()))}
    ids = back.point_data["id"][back.tets]
    src = [order[tuple(r)] for r in np.sort(ids, axis=1).tolist()]
    np.testing.assert_array_equal(back.cell_data["mat"], mesh.cell_data["mat"][src])
    quant, qhdr, *_ = round_trip(mesh)
    same_tets(quant, qhdr, quantized(mesh.points, qhdr), mesh.tets)


def test_keep_order_gives_identical_indices():
    mesh = grid_mesh(3, jitter=0.2)
    rng = np.random.default_rng(5)
    mesh = TetMesh(mesh.points, mesh.tets[rng.permutation(mesh.n_tets)])
    mesh.point_data["v"] = mesh.points.astype(np.float32) * 3
    mesh.cell_data["q"] = rng.normal(size=(mesh.n_tets, 2))
    back, hdr, stats, _ = round_trip(mesh, keep_order=True, attr_error={"q": 1e-4})
    np.testing.assert_array_equal(back.tets, mesh.tets)
    np.testing.assert_array_equal(back.points, quantized(mesh.points, hdr))
    np.testing.assert_array_equal(back.point_data["v"], mesh.point_data["v"])
    assert np.abs(back.cell_data["q"] - mesh.cell_data["q"]).max() <= 1e-4
    assert stats["fields"]["cell:q"]["mode"] == "bounded"


def test_rates_reported():
    mesh = grid_mesh(4, jitter=0.2)
    _, _, stats, blob = round_trip(mesh)
    assert stats["bits_per_tet"] == pytest.approx(8 * stats["connectivity_nbytes"] / mesh.n_tets)
    assert stats["bits_per_vertex"] == pytest.approx(8 * stats["geometry_nbytes"] / mesh.n_vertices)
    assert stats["bits_per_tet"] < 6 and stats["bits_per_vertex"] < 46  # raw: 128, 48
    assert len(blob) < (mesh.points.nbytes + mesh.n_tets * 16) / 4  # of float64 + int32


def test_refuses_bad_input():
    with pytest.raises(FormatError, match="expected 0..3"):
        compress_mesh(TetMesh(UNIT, [[0, 1, 2, 7]]), io.BytesIO())
    with pytest.raises(OptionError, match="attr_error"):
        compress_mesh(TetMesh(UNIT, [[0, 1, 2, 3]]), io.BytesIO(), attr_error={"nope": 1.0})


GOLDEN = Path(__file__).resolve().parents[2] / "formats" / "examples" / "mesh-1-grid.vpk"
GOLDEN_OPTIONS = {"keep_order": True, "attr_error": {"T": 0.01}}


def test_golden_stream_decodes_and_reencodes():
    mesh = golden_mesh()
    buf = io.BytesIO()
    compress_mesh(mesh, buf, **GOLDEN_OPTIONS)
    if os.environ.get("VOLPACK_REGEN_GOLDEN"):
        GOLDEN.write_bytes(buf.getvalue())
    blob = GOLDEN.read_bytes()
    back = decompress_mesh(blob)
    np.testing.assert_array_equal(back.tets, mesh.tets)
    with Reader(io.BytesIO(blob)) as r:
        np.testing.assert_array_equal(back.points, quantized(mesh.points, r.header))
    np.testing.assert_array_equal(back.cell_data["mat"], mesh.cell_data["mat"])
    assert np.abs(back.point_data["T"] - mesh.point_data["T"]).max() <= 0.01
    # same input, same options -> same bytes (the container's version field aside)
    assert _payloads(buf.getvalue()) == _payloads(blob)


def test_coordinates_of_an_earlier_coder_are_refused_with_the_reason():
    # streams from before the scaled residual code carry no geometry "coder"
    with Reader(io.BytesIO(GOLDEN.read_bytes())) as r:
        hdr = dict(r.header)
        payloads = {n: p for _, n, p in r}
    hdr["geometry"] = {k: v for k, v in hdr["geometry"].items() if k != "coder"}
    buf = io.BytesIO()
    with Writer(buf, hdr) as w:
        for n, p in payloads.items():
            w.write(0, n, p)
    with pytest.raises(FormatError, match="earlier volpack"):
        decompress_mesh(buf.getvalue())


def _payloads(blob):
    with Reader(io.BytesIO(blob)) as r:
        return [(t, n, p) for t, n, p in r]


def test_fuzzed_golden_stream_raises_clean_errors():
    blob = GOLDEN.read_bytes()
    rng = np.random.default_rng(11)
    cuts = sorted(set(rng.integers(0, len(blob), 25).tolist()) | {0, 10, len(blob) - 1})
    for cut in cuts:
        with pytest.raises(FormatError):
            decompress_mesh(blob[:cut])
    for pos in rng.integers(0, len(blob), 60).tolist():
        bad = bytearray(blob)
        bad[pos] ^= 1 << int(rng.integers(0, 8))
        try:
            decompress_mesh(bytes(bad))
        except FormatError:
            pass  # a clear error; anything else (or a crash) fails the test


def test_decode_refuses_other_kinds():
    from volpack import api

    blob = api.compress_array(np.zeros((4, 4, 4), dtype=np.uint8))
    with pytest.raises(FormatError, match="kind 'mesh'"):
        decompress_mesh(blob)


# --- the command line ---------------------------------------------------------------------


@pytest.fixture
def vtu(tmp_path):
    mesh = grid_mesh(3, jitter=0.2)
    path = tmp_path / "in.vtu"
    meshio.write(
        str(path),
        meshio.Mesh(
            mesh.points,
            [("tetra", mesh.tets)],
            point_data={"T": mesh.points[:, 2] * 10},
            cell_data={"mat": [np.arange(mesh.n_tets, dtype=np.int32) // 40]},
        ),
    )
    return path


def test_cli_compress_info_decompress(tmp_path, vtu):
    runner = CliRunner()
    out = tmp_path / "m.vpk"
    r = runner.invoke(
        main, ["compress", str(vtu), str(out), "--bits", "20", "--attr-error", "T=0.01", "--json"]
    )
    assert r.exit_code == 0, r.output
    stats = json.loads(r.stdout)
    assert stats["tets"] == 162 and stats["fields"]["point:T"]["max_error"] <= 0.01
    r = runner.invoke(main, ["info", str(out), "--json"])
    assert r.exit_code == 0, r.output
    info = json.loads(r.stdout)
    assert info["kind"] == "mesh" and info["tets"] == 162 and info["geometry"]["bits"] == 20
    assert info["bits_per_tet"] == pytest.approx(stats["bits_per_tet"])
    r = runner.invoke(main, ["info", str(out)])
    assert "bits/tet" in r.output and "bits/vertex" in r.output and "cell:mat" in r.output
    back_path = tmp_path / "back.vtu"
    r = runner.invoke(main, ["decompress", str(out), str(back_path)])
    assert r.exit_code == 0, r.output
    src, back = meshio.read(str(vtu)), meshio.read(str(back_path))
    with Reader(str(out)) as rd:
        expected = quantized(src.points, rd.header)
    assert tet_keys(back.points, back.cells_dict["tetra"]) == tet_keys(
        expected, src.cells_dict["tetra"]
    )
    assert np.abs(np.sort(back.point_data["T"]) - np.sort(src.point_data["T"])).max() <= 0.01
    np.testing.assert_array_equal(
        np.sort(back.cell_data["mat"][0]), np.sort(src.cell_data["mat"][0])
    )
    r = runner.invoke(main, ["info", str(vtu)])
    assert r.exit_code == 0 and "border faces" in r.output
    # the same stream on standard input
    piped = tmp_path / "piped.vtu"
    r = runner.invoke(main, ["decompress", "-", str(piped)], input=out.read_bytes())
    assert r.exit_code == 0, r.output
    np.testing.assert_array_equal(meshio.read(str(piped)).points, back.points)
    r = runner.invoke(main, ["info", "-", "--json"], input=out.read_bytes())
    assert r.exit_code == 0, r.output
    assert {**json.loads(r.stdout), "path": str(out)} == info


def test_cli_hex_needs_tetrahedralize(tmp_path):
    g = np.arange(2)
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    pts = np.stack([x, y, z], -1).reshape(-1, 3).astype(float)
    path = tmp_path / "hex.vtu"
    meshio.write(str(path), meshio.Mesh(pts, [("hexahedron", [[0, 1, 3, 2, 4, 5, 7, 6]])]))
    runner = CliRunner()
    r = runner.invoke(main, ["compress", str(path), str(tmp_path / "h.vpk")])
    assert r.exit_code == 1 and "--tetrahedralize" in r.output
    assert not (tmp_path / "h.vpk").exists()
    r = runner.invoke(
        main,
        [
            "compress",
            str(path),
            str(tmp_path / "h.vpk"),
            "--tetrahedralize",
            "--keep-order",
            "--lossless-geometry",
        ],
    )
    assert r.exit_code == 0, r.output
    back = decompress_mesh((tmp_path / "h.vpk").read_bytes())
    assert back.n_tets == 6
    np.testing.assert_array_equal(back.points, pts)


def test_cli_bad_attr_error(tmp_path, vtu):
    r = CliRunner().invoke(
        main, ["compress", str(vtu), str(tmp_path / "x.vpk"), "--attr-error", "T"]
    )
    assert r.exit_code == 2 and "NAME=ERROR" in r.output


def test_orient_saves_bits_and_keep_order_still_restores_rows():
    mesh = grid_mesh(3, jitter=0.1)
    rng = np.random.default_rng(2)
    tets = mesh.tets.copy()
    odd = rng.random(len(tets)) < 0.5  # no consistent orientation, as DOLFIN writes them
    tets[odd] = tets[odd][:, [0, 2, 1, 3]]
    mesh = TetMesh(mesh.points, tets)
    plain = round_trip(mesh, lossless_geometry=True)
    oriented = round_trip(mesh, lossless_geometry=True, orient=True)
    assert oriented[2]["connectivity_nbytes"] < plain[2]["connectivity_nbytes"]
    back = oriented[0]
    assert (signed_volumes(back.points, back.tets) > 0).all()
    assert sorted(
        map(tuple, np.sort(back.points[back.tets], axis=1).reshape(len(tets), -1).tolist())
    ) == sorted(map(tuple, np.sort(mesh.points[mesh.tets], axis=1).reshape(len(tets), -1).tolist()))
    kept = round_trip(mesh, lossless_geometry=True, orient=True, keep_order=True)[0]
    np.testing.assert_array_equal(kept.tets, mesh.tets)


def test_ascending_rows_code_no_orientation_and_decode_ascending():
    # DOLFIN writes every cell's vertices ascending, so half the tets look inverted: the
    # stream notices, codes no orientation and writes the rows ascending again
    mesh = grid_mesh(4, jitter=0.1)
    mesh = TetMesh(mesh.points, np.sort(mesh.tets, axis=1))
    assert (signed_volumes(mesh.points, mesh.tets) < 0).mean() > 0.3
    back, hdr, stats, _ = round_trip(mesh, lossless_geometry=True)
    assert hdr["rows"] == stats["rows"] == "sorted"
    same_tets(back, hdr, mesh.points, mesh.tets)
    # one row out of order: every row's parity is coded, at about a bit per tet more
    tets = mesh.tets.copy()
    tets[0] = tets[0][[1, 0, 2, 3]]
    parity = round_trip(TetMesh(mesh.points, tets), lossless_geometry=True)
    assert parity[1]["rows"] == "parity"
    assert parity[2]["bits_per_tet"] > stats["bits_per_tet"] + 0.5
    same_tets(parity[0], parity[1], mesh.points, tets)
    kept, khdr, kstats, _ = round_trip(mesh, keep_order=True)
    np.testing.assert_array_equal(kept.tets, mesh.tets)
    # the row orders are not stored: the order chunk holds the two permutations alone
    full = round_trip(TetMesh(mesh.points, tets), keep_order=True)
    np.testing.assert_array_equal(full[0].tets, tets)
    assert kstats["order_nbytes"] < full[2]["order_nbytes"]
    with pytest.raises(FormatError, match="rows 'upside-down'"):
        check_header({**hdr, "rows": "upside-down"}, 1 << 20)
