"""Tetrahedral mesh compression: the thesis's Tables 3.5-3.8 quantities on real meshes.

For each mesh (``datasets.MESH_DATASETS``, fetched from Debian packages into the cache
folder; real surfaces filled with tets by tetgen or gmsh, ``mesh_surfaces.RECIPES``, named
``<surface>_<mesher>`` and cached under ``<data>/meshed/``; plus the thesis's "Random"
case: the Delaunay tetrahedralisation of 2,000 random points, with scipy) it measures

* v:e:f:t, border faces, operation frequencies of the cut-border machine (Table 3.5/3.6);
* connectivity bits per tet and per vertex, from the order-0 entropy of the operations
  and from the adaptive coder's stream, and bits per border face (Table 3.7);
* coordinate bits per vertex at 16-bit quantisation and lossless (Table 3.7), with two
  lossless baselines on the same coding order: zstd of the float bytes, and zstd of the
  XOR of each vertex's bit pattern with the previous vertex's;
* tets/s to encode and decode the connectivity alone and the whole ``.vpk`` stream;
* baselines in the same run: raw int32 indices, zstd (level 19) and xz (preset 9) of
  them, and meshio's zlib-compressed VTU file (the whole mesh: indices, coordinates,
  cell types and offsets).

Writes ``results/tetra/tetra.csv``, ``tetra.png`` and ``table.md`` (or into ``--out``)
and prints the markdown table.

    python scripts/bench_tetra.py                # every mesh (fetches what is missing)
    python scripts/bench_tetra.py --quick        # the small ones only
    python scripts/bench_tetra.py --only femur_tetgen,aneurysm_gmsh --out /tmp/t
"""

from __future__ import annotations

import argparse
import csv
import io
import lzma
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import zstandard

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402
import fetch_data  # noqa: E402
import mesh_surfaces  # noqa: E402

from volpack.tetra import cutborder, geometry  # noqa: E402
from volpack.tetra.formats import read_mesh, write_mesh  # noqa: E402
from volpack.tetra.mesh import TetMesh, signed_volumes  # noqa: E402
from volpack.tetra.stream import compress_mesh, decompress_mesh, row_convention  # noqa: E402

OUT = Path(__file__).resolve().parent.parent / "results" / "tetra"
QUICK = ("elbow2", "cube_sphere", "box_with_dent", "cgal_sphere", "segmenttet", "t13_gmsh")
MESHES = [*datasets.MESH_DATASETS, *mesh_surfaces.RECIPES]


def load_meshes(names, tmp: Path) -> tuple[dict[str, TetMesh], dict[str, str]]:
    """The meshes by name, and who made each meshed surface (e.g. ``"gmsh 4.15.2"``)."""
    meshes, meshers = {}, {}
    for name in names:
        try:
            if name in mesh_surfaces.RECIPES:
                meshes[name], meshers[name] = mesh_surfaces.meshed(name, tmp)
                continue
            path, _ = fetch_data.fetch_dataset(datasets.MESH_DATASETS[name], tmp)
        except Exception as exc:  # a missing package or mesher should not stop the others
            print(f"{name}: not available ({exc})", file=sys.stderr)
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            meshes[name] = read_mesh(str(path))
    return meshes, meshers


def random_mesh(n: int = 2000, seed: int = 0) -> TetMesh:
    from scipy.spatial import Delaunay

    pts = np.random.default_rng(seed).random((n, 3))
    return TetMesh(pts, Delaunay(pts).simplices)


def best_of(fn, repeat: int = 3) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def measure(name: str, mesh: TetMesh) -> dict:
    nv, nt = mesh.n_vertices, mesh.n_tets
    row: dict = {"mesh": name, "real": name != "Random"}
    # the stream's default: rows that all ascend (DOLFIN) code no orientation
    rows = row_convention(mesh.tets)
    keep = rows != "sorted"
    st = cutborder.connectivity_stats(mesh.tets, nv, keep_orientation=keep)
    v = max(st["v"], 1)
    row.update(
        v=st["v"], e=st["e"], f=st["f"], t=st["t"], b=st["b"],
        vef_t=f"1:{st['e'] / v:.2f}:{st['f'] / v:.2f}:{st['t'] / v:.2f}",
        nu_border=st["nu_border"], nu_new=st["nu_new"], nu_c0=st["nu_connect0"],
        nu_c1=st["nu_connect1"], nu_c2=st["nu_connect2"], nu_cgt2=st["nu_connect_gt2"],
        nu_far=st["nu_far"], nu_nm=st["nu_nonmanifold"],
        conn_entropy_bpt=st["entropy_bits_per_tet"], conn_adaptive_bpt=st["adaptive_bits_per_tet"],
        conn_entropy_bpv=st["entropy_bits_per_vertex"], conn_adaptive_bpv=st["adaptive_bits_per_vertex"],
        border_bits_per_face=st["border_bits_per_border_face"],
    )  # fmt: skip
    # rows turned to positive volume (volpack compress --orient): no orientation flags
    vol = signed_volumes(mesh.points, mesh.tets)
    oriented = mesh.tets.copy()
    oriented[vol < 0] = oriented[vol < 0][:, [1, 0, 2, 3]]
    conn_o, _ = cutborder.encode_connectivity(oriented, nv)
    row["conn_oriented_bpt"] = 8 * len(conn_o) / nt
    # every row's parity coded, whatever the rows' convention
    conn_p, _ = cutborder.encode_connectivity(mesh.tets, nv)
    row["rows"], row["conn_parity_bpt"] = rows, 8 * len(conn_p) / nt
    # connectivity speed, alone
    t_enc, (conn, trav) = best_of(
        lambda: cutborder.encode_connectivity(mesh.tets, nv, keep_orientation=keep)
    )
    t_dec, _ = best_of(lambda: cutborder.decode_connectivity(conn))
    row["conn_enc_tets_s"], row["conn_dec_tets_s"] = nt / t_enc, nt / t_dec
    # coordinates in coding order
    pts = mesh.points[trav.vertex_order]
    ctets = np.asarray(trav.tets, dtype=np.int64)
    g16, meta = geometry.encode_geometry(pts, ctets, bits=16)
    glossless, _ = geometry.encode_geometry(pts, ctets, lossless=True)
    row["geo16_bpv"] = 8 * len(g16) / nv
    row["geo16_max_error_rel"] = meta["max_error"] / float(np.linalg.norm(np.ptp(pts, axis=0)))
    row["geo_lossless_bpv"] = 8 * len(glossless) / nv
    row["coord_dtype"] = pts.dtype.name
    zc = zstandard.ZstdCompressor(level=19)
    bits = pts.view(f"u{pts.itemsize}")
    xor = bits.copy()
    xor[1:] ^= bits[:-1]
    row["geo_zstd_bpv"] = 8 * len(zc.compress(pts.tobytes())) / nv
    row["geo_xor_zstd_bpv"] = 8 * len(zc.compress(xor.tobytes())) / nv

    # whole stream, end to end
    def enc():
        buf = io.BytesIO()
        compress_mesh(mesh, buf)
        return buf.getvalue()

    t_senc, blob = best_of(enc)
    t_sdec, back = best_of(lambda: decompress_mesh(blob))
    assert back.n_tets == nt
    row["stream_bytes"] = len(blob)
    row["enc_tets_s"], row["dec_tets_s"] = nt / t_senc, nt / t_sdec
    # baselines on the indices
    idx = mesh.tets.astype("<i4").tobytes()
    row["raw_bpt"] = 8 * len(idx) / nt
    row["zstd_bpt"] = 8 * len(zc.compress(idx)) / nt
    row["xz_bpt"] = 8 * len(lzma.compress(idx, preset=9)) / nt
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "m.vtu"
        write_mesh(TetMesh(mesh.points, mesh.tets), str(p))
        row["vtu_bytes"] = p.stat().st_size
    row["vtu_over_vpk"] = row["vtu_bytes"] / len(blob)
    return row


def chart(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = [r["mesh"] for r in rows]
    x = np.arange(len(rows))
    fig, (a, b) = plt.subplots(1, 2, figsize=(13, 4.5))
    w = 0.2
    for i, (key, label) in enumerate(
        [("conn_adaptive_bpt", "cut-border (adaptive)"), ("conn_entropy_bpt", "cut-border (entropy)"),
         ("xz_bpt", "xz -9 of int32 indices"), ("zstd_bpt", "zstd -19 of int32 indices")]
    ):  # fmt: skip
        a.bar(x + (i - 1.5) * w, [r[key] for r in rows], w, label=label)
    a.axhline(2.0, color="k", lw=0.8, ls="--")
    a.set_yscale("log")
    a.set_ylabel("connectivity, bits per tet")
    a.set_xticks(x, names, rotation=40, ha="right")
    a.legend(fontsize=8)
    for i, (key, label) in enumerate(
        [("geo16_bpv", "16-bit, predicted"), ("geo_lossless_bpv", "lossless, predicted"),
         ("geo_xor_zstd_bpv", "lossless, XOR + zstd")]
    ):  # fmt: skip
        b.bar(x + (i - 1) * 0.27, [r[key] for r in rows], 0.27, label=label)
    b.axhline(30.0, color="k", lw=0.8, ls="--")
    b.set_ylabel("coordinates, bits per vertex")
    b.set_xticks(x, names, rotation=40, ha="right")
    b.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="only the small meshes")
    ap.add_argument("names", nargs="*", help="meshes to run (default: all)")
    ap.add_argument(
        "--only", metavar="NAME[,NAME]", help="just these meshes (Random only if named)"
    )
    ap.add_argument("--out", type=Path, default=OUT, help=f"output folder (default {OUT})")
    args = ap.parse_args(argv)
    only = args.only.split(",") if args.only else []
    names = only or args.names or (list(QUICK) if args.quick else MESHES)
    unknown = [n for n in names if n not in MESHES and n != "Random"]
    if unknown:
        ap.error(f"unknown mesh(es) {', '.join(unknown)}; expected some of {', '.join(MESHES)}")
    with tempfile.TemporaryDirectory(prefix="volpack-fetch-") as tmp:
        meshes, meshers = load_meshes([n for n in names if n != "Random"], Path(tmp))
    random = random_mesh()
    if not only or "Random" in only:
        meshes["Random"] = random
    cutborder.encode_connectivity(random.tets[:50], random.n_vertices)
    compress_mesh(random, io.BytesIO())  # compile before timing
    rows = []
    for name, mesh in meshes.items():
        row = measure(name, mesh)
        row["mesher"] = meshers.get(name, "")
        rows.append(row)
        print(
            f"{name:18s} t={row['t']:7d} conn {row['conn_adaptive_bpt']:.2f} b/t "
            f"geo {row['geo16_bpv']:.2f} b/v enc {row['enc_tets_s'] / 1e3:.0f}k/s",
            file=sys.stderr,
        )
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "tetra.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    chart(rows, out / "tetra.png")
    real = [r for r in rows if r["real"]]
    lines = []
    emit = lines.append  # the table goes to stdout and to table.md
    emit(
        "| mesh | v | t | v:e:f:t | b | ν* | ν∞0 | rows | conn. bits/tet entropy / adaptive / "
        "every parity / --orient | "
        "bits/vertex | bits/border face | zstd / xz of indices, bits/tet | coords 16-bit, bits/vertex "
        "| lossless (XOR+zstd) | encode / decode, ktets/s | VTU / vpk size |"
    )
    emit("|" + "---|" * 16)
    for r in rows:
        emit(
            f"| {r['mesh']} | {r['v']} | {r['t']} | {r['vef_t']} | {r['b']} | {r['nu_new']:.3f} | "
            f"{r['nu_c0']:.3f} | {r['rows']} | {r['conn_entropy_bpt']:.2f} / "
            f"{r['conn_adaptive_bpt']:.2f} / {r['conn_parity_bpt']:.2f} / "
            f"{r['conn_oriented_bpt']:.2f} | "
            f"{r['conn_adaptive_bpv']:.2f} | {r['border_bits_per_face']:.2f} | "
            f"{r['zstd_bpt']:.1f} / {r['xz_bpt']:.1f} | {r['geo16_bpv']:.2f} | "
            f"{r['geo_lossless_bpv']:.1f} ({r['geo_xor_zstd_bpv']:.1f}) | "
            f"{r['enc_tets_s'] / 1e3:.0f} / {r['dec_tets_s'] / 1e3:.0f} | {r['vtu_over_vpk']:.1f} |"
        )
    if real:
        emit(
            f"\nmean over {len(real)} real meshes: connectivity "
            f"{np.mean([r['conn_adaptive_bpt'] for r in real]):.3f} bits/tet (adaptive), "
            f"{np.mean([r['conn_entropy_bpt'] for r in real]):.3f} (entropy), "
            f"{np.mean([r['conn_parity_bpt'] for r in real]):.3f} (every parity coded), "
            f"{np.mean([r['conn_oriented_bpt'] for r in real]):.3f} (--orient); coordinates "
            f"{np.mean([r['geo16_bpv'] for r in real]):.2f} bits/vertex at 16 bits; "
            f"encode {np.mean([r['enc_tets_s'] for r in real]) / 1e3:.0f}k tets/s, decode "
            f"{np.mean([r['dec_tets_s'] for r in real]) / 1e3:.0f}k tets/s (whole stream); "
            f"connectivity alone {np.mean([r['conn_enc_tets_s'] for r in real]) / 1e3:.0f}k / "
            f"{np.mean([r['conn_dec_tets_s'] for r in real]) / 1e3:.0f}k tets/s"
        )
    text = "\n".join(lines) + "\n"
    (out / "table.md").write_text(text)
    sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
